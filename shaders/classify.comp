#version 450
// MC33 classification (shaders/classify.glsl).
#extension GL_GOOGLE_include_directive : require
#include "shaders/classify.glsl"
