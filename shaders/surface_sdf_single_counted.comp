#version 450
// The surface SDF with one walk per invocation whose loop count (kernels/sdf.h's loop budget) is
// kept per subgroup with subgroupMax: on llvmpipe a subgroup is the SIMD batch its loop limit
// counts for, so the whole limit is usable, not a lane's share of it. For devices with subgroup
// arithmetic that run under a budget (host/backends/vulkan.cpp picks).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#define GROUP_MAX(x) subgroupMax(x)
#extension GL_GOOGLE_include_directive : require
#include "shaders/surface_sdf.glsl"
