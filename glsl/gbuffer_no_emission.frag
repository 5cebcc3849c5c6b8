#version 460
// The G-buffer of a scene without emissive materials: no emission target
// (glsl/include/gbuffer_frag.glsl).
#define GBUFFER_NO_EMISSION
#include "gbuffer_frag.glsl"
