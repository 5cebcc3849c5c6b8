#version 460
// Deferred lighting and composite: for every pixel, emission plus the sum over lights of
// BRDF * irradiance * cos * shadow visibility (shadow maps, or traced shadow cones or rays), plus
// with GI the indirect light: (albedo * diffuse-cone mean radiance + Ks * specular-cone
// radiance) * AO, or with ray-traced reflections albedo * diffuse * AO + Ks * reflections.
// Where no surface is, the sky. Output: linear radiance W/(sr m^2), or a debug view of the
// indirect light.
#include "common.glsl"
#include "brdf.glsl"
#include "lights.glsl"
#define SHADOW_VIEWS_BINDING 2
#include "shadow.glsl"
#include "gbuffer_read.glsl"
#include "sky.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const bool GI = false;
layout(constant_id = 1) const bool GI_SPECULAR = false;
layout(constant_id = 2) const bool TRACED_SHADOWS = false;  // lights 0..3: gi_shadow (cones or rays)
layout(constant_id = 3) const uint OUTPUT = 0;  // 0 final, 1 indirect light only, 2 AO factor
// The specular target holds ray-traced reflections (gi.specular = "rt"): rays see occlusion
// themselves, so the AO factor does not dim them.
layout(constant_id = 4) const bool RT_SPECULAR = false;
// Some material emits: the G-buffer has an emission target (else g_emission is another target,
// not read).
layout(constant_id = 5) const bool EMISSION = true;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, std430) readonly buffer Lights { Light lights[]; };
layout(set = 0, binding = 3) uniform sampler2D g_depth;
layout(set = 0, binding = 4) uniform sampler2D g_albedo;
layout(set = 0, binding = 5) uniform sampler2D g_normal;
layout(set = 0, binding = 6) uniform sampler2D g_specular;
layout(set = 0, binding = 7) uniform sampler2D g_emission;
layout(set = 0, binding = 8) uniform sampler2DArrayShadow shadow_map;
layout(set = 0, binding = 9, rgba32f) uniform writeonly image2D out_radiance;
layout(set = 0, binding = 10, rgba16f) uniform readonly image2D gi_diffuse;
layout(set = 0, binding = 11, rgba16f) uniform readonly image2D gi_specular;
layout(set = 0, binding = 12, rgba8) uniform readonly image2D gi_shadow;
layout(set = 0, binding = 13) uniform sampler2D sky_map;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    uvec2 size = frame.counts.xy;
    if (any(greaterThanEqual(uvec2(px), size))) return;

    float depth = texelFetch(g_depth, px, 0).r;
    if (depth >= 1.0) {
        // Background: the sky along the pixel's ray from the near plane to the far one, as the
        // path tracer's camera rays go (black without a sky, and in the indirect and AO views).
        vec3 d = normalize(world_position(frame, px, 1.0) - world_position(frame, px, 0.0));
        vec3 sky = OUTPUT == 0u ? sky_radiance(sky_map, frame.sky, d) : vec3(0.0);
        imageStore(out_radiance, px, vec4(sky, 1.0));
        return;
    }
    vec3 P = world_position(frame, px, depth);
    vec4 albedo_facing = texelFetch(g_albedo, px, 0);
    vec3 albedo = albedo_facing.rgb;
    vec4 ns = texelFetch(g_normal, px, 0);
    vec3 N = safe_normalize(ns.xyz, vec3(0.0, 1.0, 0.0));
    // The normal is a footprint's mean (gbuffer.frag), shorter than 1 where a normal or height
    // map's normals disagree: the diffuse term takes the mean's cosine, |mean| (N . l), the
    // mean of its normals' cosines wherever none faces away (material.glsl); the specular
    // lobe takes the mean's direction. Within the 16-bit float storage's error of a unit
    // normal the length is 1, so unmapped surfaces shade as they did.
    float agreement = length(ns.xyz);
    agreement = agreement >= 1.0 - HALF_NORMAL_ERROR ? 1.0 : agreement;
    vec4 ks_facing = texelFetch(g_specular, px, 0);
    vec3 ks = ks_facing.rgb;
    vec3 ng = oct_decode(vec2(albedo_facing.a, ks_facing.a));
    vec3 V = safe_normalize(frame.camera_pos.xyz - P, N);

    float unscale = frame.radiance_scale.y;  // 16-bit inputs hold radiance * scale
    vec3 radiance = EMISSION ? texelFetch(g_emission, px, 0).rgb * unscale : vec3(0.0);
    vec4 traced_vis = TRACED_SHADOWS ? imageLoad(gi_shadow, px) : vec4(1.0);
    uint light_count = frame.counts.z;
    for (uint i = 0u; i < light_count; ++i) {
        Light l = lights[i];
        LightSample s = sample_light(l, P);
        float cos_theta = dot(N, s.wi);
        // Light from behind the geometric surface is blocked (the path tracer's rule), also
        // where a smoothed shading normal still faces it.
        if (cos_theta <= 0.0 || dot(ng, s.wi) <= 0.0 || max(s.irradiance.r, max(s.irradiance.g, s.irradiance.b)) <= 0.0) {
            continue;
        }
        float vis = 1.0;
        if (TRACED_SHADOWS && i < 4u) {
            vis = traced_vis[i];
        } else if (l.shadow.x >= 0) {
            int layer = shadow_view_index(l, P, frame.shadow.x + 1.5 * frame.shadow.y + 2.0, frame.shadow.z);
            // The bias against acne follows the geometric surface, the receiver's plane.
            vis = shadow_visibility(shadow_map, views[layer], layer, P, ng, s.wi, s.distance,
                                    frame.shadow.x, frame.shadow.y, frame.shadow.z);
        }
        vec3 f = brdf_diffuse(albedo) * agreement + brdf_specular(ks, ns.a, N, V, s.wi);
        radiance += f * s.irradiance * cos_theta * vis;
    }
    vec3 indirect = vec3(0.0);
    float ao = 1.0;
    if (GI) {
        vec4 d = imageLoad(gi_diffuse, px);
        ao = clamp(d.a, 0.0, 1.0);
        indirect = albedo * max(d.rgb, vec3(0.0)) * unscale;
        if (GI_SPECULAR) indirect += ks * max(imageLoad(gi_specular, px).rgb, vec3(0.0)) * unscale;
        indirect *= ao;
        if (RT_SPECULAR) indirect += ks * max(imageLoad(gi_specular, px).rgb, vec3(0.0)) * unscale;
    }
    vec3 result = OUTPUT == 1u ? indirect : (OUTPUT == 2u ? vec3(ao) : radiance + indirect);
    imageStore(out_radiance, px, vec4(result, 1.0));
}
