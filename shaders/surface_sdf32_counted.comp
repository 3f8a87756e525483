#version 450
// The fp32 path's surface SDF (shaders/surface_sdf32.glsl) with its loop count kept per subgroup
// (subgroupMax): on llvmpipe a subgroup is the SIMD batch the loop limit counts for, so the whole
// limit is usable. For devices with subgroup arithmetic (host/backends/vulkan.cpp picks).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#define GROUP_MAX(x) subgroupMax(x)
#extension GL_GOOGLE_include_directive : require
#include "shaders/surface_sdf32.glsl"
