#version 450
// shaders/surface_sdf_single_counted.comp reading the scene's search arrays from uniform texel
// buffers (shaders/surface_sdf.glsl MCHEX_TEXEL_SCENE) and measuring every triangle of a leaf in
// range without its bound (kernels/sdf.h MCHEX_SDF_LEAF_BOUNDS): llvmpipe's default.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#define GROUP_MAX(x) subgroupMax(x)
#define MCHEX_TEXEL_SCENE
#define MCHEX_SDF_LEAF_BOUNDS 0
#extension GL_GOOGLE_include_directive : require
#include "shaders/surface_sdf.glsl"
