#version 450
// The surface SDF with the subgroup walk (kernels/sdf.h MCHEX_SDF_SUBGROUP): a subgroup's
// invocations share one walk of the tree for their points. Needs subgroup basic and arithmetic
// operations in compute shaders (host/backends/vulkan.cpp checks; else surface_sdf_single.comp).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#define MCHEX_SDF_SUBGROUP
#define GROUP_MIN(x) subgroupMin(x)
#define GROUP_MAX(x) subgroupMax(x)
#extension GL_GOOGLE_include_directive : require
#include "shaders/surface_sdf.glsl"
