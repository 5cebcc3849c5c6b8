#version 460
// Reflective-shadow-map indirect light (Dachsbacher & Stamminger 2005), one diffuse bounce per
// traced pixel: around the pixel's position in each light's map, SAMPLES texels on a golden-
// angle spiral whose radii are stratified uniformly in [0, RADIUS] (so samples crowd near the
// pixel, where texels matter most, and each stands for the annulus it sits in: 2 pi r dR of
// the map). Each texel is a Lambertian area light of flux Phi: it gives the pixel irradiance
// Phi/pi cos_p cos_x / d^2 (no visibility: RSM's known limit). Writes the mean incoming
// radiance E/pi (times the radiance scale) like the cone tracer, with a = 1 (no AO).
#include "common.glsl"
#include "cone_params.glsl"
#include "gbuffer_read.glsl"
#define SHADOW_VIEWS_BINDING 2
#include "shadow.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const uint VIEW_COUNT = 1;
layout(constant_id = 1) const uint SAMPLES = 64;
layout(constant_id = 2) const float RADIUS = 0.25;  // fraction of the map's side
// `rsm+lpv`: only texels nearer than this (world units) count, the light propagation volume
// gives the rest; 0: every texel.
layout(constant_id = 3) const float NEAR = 0.0;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1) uniform GiBlock { GiParams gi; };
layout(set = 0, binding = 3, std430) readonly buffer RsmViews { uvec4 rsm_views[]; };  // x shadow view
layout(set = 0, binding = 4) uniform sampler2D g_depth;
layout(set = 0, binding = 5) uniform sampler2D g_normal;
layout(set = 0, binding = 6) uniform sampler2DArray rsm_flux;
layout(set = 0, binding = 7) uniform sampler2DArray rsm_normal;
layout(set = 0, binding = 8) uniform sampler2DArray rsm_position;
layout(set = 0, binding = 9, rgba16f) uniform writeonly image2D out_diffuse;

const float GOLDEN_ANGLE = 2.39996323;

// Interleaved gradient noise (Jimenez 2014): a per-pixel rotation of the spiral, so that
// neighbouring pixels sample different texels and the upsample averages them.
float pixel_noise(ivec2 px) {
    return fract(52.9829189 * fract(dot(vec2(px), vec2(0.06711056, 0.00583715))));
}

// Irradiance at P (normal N) from one map, gathered around `centre` (map coordinates in [0,1]).
vec3 gather(uint layer, vec2 centre, vec3 P, vec3 N, float rotation) {
    ivec2 size = textureSize(rsm_flux, 0).xy;
    // Map area a sample at radius r stands for, in texels: 2 pi r dR, dR = RADIUS / SAMPLES.
    float texels_per_r = 2.0 * PI * RADIUS / float(SAMPLES) * float(size.x) * float(size.y);
    vec3 e = vec3(0.0);
    for (uint i = 0u; i < SAMPLES; ++i) {
        float r = RADIUS * (float(i) + 0.5) / float(SAMPLES);
        float a = rotation + float(i) * GOLDEN_ANGLE;
        vec2 uv = centre + r * vec2(cos(a), sin(a));
        if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) continue;
        ivec3 t = ivec3(min(ivec2(uv * vec2(size)), size - 1), int(layer));
        vec4 flux = texelFetch(rsm_flux, t, 0);
        if (flux.a <= 0.0) continue;  // no surface in this texel
        vec3 d = P - texelFetch(rsm_position, t, 0).xyz;
        vec3 np = texelFetch(rsm_normal, t, 0).xyz;
        float d2 = dot(d, d);
        if (NEAR > 0.0 && d2 >= NEAR * NEAR) continue;
        float len = sqrt(d2);
        float cos_p = max(dot(np, d), 0.0) / max(len, 1e-20);
        float cos_x = max(-dot(N, d), 0.0) / max(len, 1e-20);
        // No nearer than the texel's own size: a texel is a patch, not a point.
        e += flux.rgb * (cos_p * cos_x / (PI * max(d2, flux.a))) * r;
    }
    return e * texels_per_r;
}

void main() {
    ivec2 lo = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(lo, imageSize(out_diffuse)))) return;
    int k = int(gi.counts.y);
    ivec2 px = min(lo * k + k / 2, ivec2(frame.counts.xy) - 1);
    float depth = texelFetch(g_depth, px, 0).r;
    if (depth >= 1.0) {
        imageStore(out_diffuse, lo, vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    vec3 P = world_position(frame, px, depth);
    vec3 N = safe_normalize(texelFetch(g_normal, px, 0).xyz, vec3(0.0, 1.0, 0.0));
    float rotation = 2.0 * PI * pixel_noise(lo);
    vec3 e = vec3(0.0);
    for (uint v = 0u; v < VIEW_COUNT; ++v) {
        vec4 c = views[rsm_views[v].x].view_proj * vec4(P, 1.0);
        // Behind a perspective view (a point light's other faces), the direction still says
        // which edge of the map is nearest the pixel; the disc is centred on that edge.
        vec2 centre = clamp(c.xy / max(abs(c.w), 1e-20) * 0.5 + 0.5, vec2(0.0), vec2(1.0));
        e += gather(v, centre, P, N, rotation);
    }
    vec3 mean_radiance = max(e, vec3(0.0)) / PI * frame.radiance_scale.x;
    imageStore(out_diffuse, lo, vec4(min(mean_radiance, vec3(HALF_MAX)), 1.0));
}
