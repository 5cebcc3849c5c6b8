#version 460
// Joint bilateral upsample (and blur) of the reduced-resolution cone-tracing results: each
// full-resolution pixel blends the 4x4 nearest traced pixels, weighted by a spatial Gaussian,
// by how close each traced sample lies to this pixel's tangent plane, and by normal agreement.
// Where no neighbour is on the same surface, the most similar one is used.
#include "common.glsl"
#include "cone_params.glsl"
#include "gbuffer_read.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const bool HAS_SPECULAR = false;
layout(constant_id = 1) const bool CONE_SHADOWS = false;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1) uniform GiBlock { GiParams gi; };
layout(set = 0, binding = 2) uniform sampler2D g_depth;
layout(set = 0, binding = 3) uniform sampler2D g_normal;
layout(set = 0, binding = 4, rgba16f) uniform readonly image2D lo_diffuse;
layout(set = 0, binding = 5, rgba16f) uniform readonly image2D lo_specular;
layout(set = 0, binding = 6, rgba8) uniform readonly image2D lo_shadow;
layout(set = 0, binding = 7, rgba16f) uniform writeonly image2D out_diffuse;
layout(set = 0, binding = 8, rgba16f) uniform writeonly image2D out_specular;
layout(set = 0, binding = 9, rgba8) uniform writeonly image2D out_shadow;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(frame.counts.xy);
    if (any(greaterThanEqual(px, size))) return;
    float depth = texelFetch(g_depth, px, 0).r;
    if (depth >= 1.0) {
        imageStore(out_diffuse, px, vec4(0.0, 0.0, 0.0, 1.0));
        if (HAS_SPECULAR) imageStore(out_specular, px, vec4(0.0));
        if (CONE_SHADOWS) imageStore(out_shadow, px, vec4(1.0));
        return;
    }
    int k = int(gi.counts.y);
    ivec2 lo_size = imageSize(lo_diffuse);
    vec3 P = world_position(frame, px, depth);
    vec3 N = safe_normalize(texelFetch(g_normal, px, 0).xyz, vec3(0.0, 1.0, 0.0));
    // Tolerance for the distance to the tangent plane: a few pixel footprints.
    float footprint = distance(P, frame.camera_pos.xyz) * 2.0 / (abs(frame.proj[1][1]) * float(size.y));
    float plane_tol = max(footprint * float(k) * 2.0, 1e-6);
    vec2 q = (vec2(px) + 0.5) / float(k) - 0.5;  // position in traced-pixel coordinates
    ivec2 base = ivec2(floor(q)) - 1;

    vec4 sd = vec4(0.0), ss = vec4(0.0), sh = vec4(0.0);
    float total = 0.0;
    float best = -1.0;
    ivec2 best_lo = clamp(ivec2(round(q)), ivec2(0), lo_size - 1);
    for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) {
            ivec2 lo = base + ivec2(i, j);
            if (any(lessThan(lo, ivec2(0))) || any(greaterThanEqual(lo, lo_size))) continue;
            ivec2 spx = min(lo * k + k / 2, size - 1);
            float sdepth = texelFetch(g_depth, spx, 0).r;
            if (sdepth >= 1.0) continue;
            vec3 sP = world_position(frame, spx, sdepth);
            vec3 sN = safe_normalize(texelFetch(g_normal, spx, 0).xyz, vec3(0.0, 1.0, 0.0));
            float plane = abs(dot(N, sP - P)) / plane_tol;
            float similar = pow(max(dot(N, sN), 0.0), 8.0) * exp(-plane * plane);
            vec2 dq = vec2(lo) - q;
            float w = exp(-dot(dq, dq) / (2.0 * 0.8 * 0.8)) * similar;
            if (similar > best) {
                best = similar;
                best_lo = lo;
            }
            sd += w * imageLoad(lo_diffuse, lo);
            if (HAS_SPECULAR) ss += w * imageLoad(lo_specular, lo);
            if (CONE_SHADOWS) sh += w * imageLoad(lo_shadow, lo);
            total += w;
        }
    }
    if (total > 1e-6) {
        sd /= total;
        ss /= total;
        sh /= total;
    } else {
        sd = imageLoad(lo_diffuse, best_lo);
        if (HAS_SPECULAR) ss = imageLoad(lo_specular, best_lo);
        if (CONE_SHADOWS) sh = imageLoad(lo_shadow, best_lo);
    }
    imageStore(out_diffuse, px, sd);
    if (HAS_SPECULAR) imageStore(out_specular, px, ss);
    if (CONE_SHADOWS) imageStore(out_shadow, px, sh);
}
