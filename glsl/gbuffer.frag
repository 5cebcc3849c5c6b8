#version 460
// The G-buffer with its emission target (glsl/include/gbuffer_frag.glsl).
#include "gbuffer_frag.glsl"
