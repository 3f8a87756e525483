#version 450
// The fp32 path's surface SDF (shaders/surface_sdf32.glsl), each invocation counting its own
// loops for the loop budget: for devices without subgroup arithmetic in compute shaders
// (host/backends/vulkan.cpp picks).
#extension GL_GOOGLE_include_directive : require
#include "shaders/surface_sdf32.glsl"
