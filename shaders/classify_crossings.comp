#version 450
// MC33 classification that also writes the 12 crossing parameters per cell (shaders/classify.glsl).
#define MCHEX_CLASSIFY_CROSSINGS
#extension GL_GOOGLE_include_directive : require
#include "shaders/classify.glsl"
