// Reading the G-buffer in compute: world position from depth, normal + shininess.
#ifndef DVSGI_GBUFFER_READ_GLSL
#define DVSGI_GBUFFER_READ_GLSL
#include "common.glsl"

// World position of full-resolution pixel px (at its centre) with depth `depth`.
vec3 world_position(FrameData f, ivec2 px, float depth) {
    vec2 ndc_xy = (vec2(px) + 0.5) / vec2(f.counts.xy) * 2.0 - 1.0;
    vec4 world = f.inv_view_proj * vec4(ndc_xy, depth, 1.0);
    return world.xyz / world.w;
}

#endif
