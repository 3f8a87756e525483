#version 450
// The surface SDF with one walk per invocation (kernels/sdf.h without a group): for devices
// without subgroup arithmetic in compute shaders, and GPUs (host/backends/vulkan.cpp picks).
#extension GL_GOOGLE_include_directive : require
#include "shaders/surface_sdf.glsl"
