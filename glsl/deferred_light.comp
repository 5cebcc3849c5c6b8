#version 460
// Deferred direct lighting: for every pixel, emission plus the sum over lights of
// BRDF * irradiance * cos * shadow visibility. Output: linear radiance W/(sr m^2).
#include "common.glsl"
#include "brdf.glsl"
#include "lights.glsl"
#include "shadow.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, std430) readonly buffer Lights { Light lights[]; };
layout(set = 0, binding = 2, std430) readonly buffer ShadowViews { ShadowView views[]; };
layout(set = 0, binding = 3) uniform sampler2D g_depth;
layout(set = 0, binding = 4) uniform sampler2D g_albedo;
layout(set = 0, binding = 5) uniform sampler2D g_normal;
layout(set = 0, binding = 6) uniform sampler2D g_specular;
layout(set = 0, binding = 7) uniform sampler2D g_emission;
layout(set = 0, binding = 8) uniform sampler2DArrayShadow shadow_map;
layout(set = 0, binding = 9, rgba32f) uniform writeonly image2D out_radiance;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    uvec2 size = frame.counts.xy;
    if (any(greaterThanEqual(uvec2(px), size))) return;

    float depth = texelFetch(g_depth, px, 0).r;
    if (depth >= 1.0) {
        imageStore(out_radiance, px, vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    vec2 ndc_xy = (vec2(px) + 0.5) / vec2(size) * 2.0 - 1.0;
    vec4 world = frame.inv_view_proj * vec4(ndc_xy, depth, 1.0);
    vec3 P = world.xyz / world.w;
    vec3 albedo = texelFetch(g_albedo, px, 0).rgb;
    vec4 ns = texelFetch(g_normal, px, 0);
    vec3 N = safe_normalize(ns.xyz, vec3(0.0, 1.0, 0.0));
    vec3 ks = texelFetch(g_specular, px, 0).rgb;
    vec3 V = safe_normalize(frame.camera_pos.xyz - P, N);

    vec3 radiance = texelFetch(g_emission, px, 0).rgb;
    uint light_count = frame.counts.z;
    for (uint i = 0u; i < light_count; ++i) {
        Light l = lights[i];
        LightSample s = sample_light(l, P);
        float cos_theta = dot(N, s.wi);
        if (cos_theta <= 0.0 || max(s.irradiance.r, max(s.irradiance.g, s.irradiance.b)) <= 0.0) {
            continue;
        }
        float vis = 1.0;
        if (l.shadow.x >= 0) {
            int layer = shadow_view_index(l, P);
            vis = shadow_visibility(shadow_map, views[layer], layer, P, N, s.wi, s.distance,
                                    frame.shadow.x, frame.shadow.y, frame.shadow.z);
        }
        vec3 f = brdf_diffuse(albedo) + brdf_specular(ks, ns.a, N, V, s.wi);
        radiance += f * s.irradiance * cos_theta * vis;
    }
    imageStore(out_radiance, px, vec4(radiance, 1.0));
}
