// A scene texture at level 0 (the full-resolution truth), for shaders that sample at points
// other than their own raster's (the path tracer, ray-traced reflections). The including
// shader declares TEXTURE_COUNT, `textures[]` and `texture_sampler` (material.glsl), the latter
// an explicit-level sampler without anisotropy: lavapipe applies anisotropy to explicit-level
// lookups in compute shaders and blurs them. It also enables GL_EXT_control_flow_attributes.
#ifndef DVSGI_SCENE_TEXEL_GLSL
#define DVSGI_SCENE_TEXEL_GLSL
#include "material.glsl"

// Bilinear, level 0. A uniform loop index: no non-uniform descriptor indexing needed (lavapipe
// has none). The loop is kept a loop: unrolled, it puts one lookup per scene texture at every
// call site (Crytek's Sponza: 37 textures, 7 call sites in the path tracer), and lavapipe
// takes seconds longer to compile the shader.
vec4 texel(int tex, vec2 uv) {
    vec4 c = vec4(1.0);
    [[dont_unroll]] for (uint i = 0u; i < TEXTURE_COUNT; ++i) {
        if (i == uint(tex)) c = textureLod(SCENE_TEXTURE(i), uv, 0.0);
    }
    return c;
}

#endif
