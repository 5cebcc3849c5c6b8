#version 460
// Ray-traced reflections (gi.specular = "rt"), at 1/k of the image resolution like the cone
// tracer, into the same specular target: for the centre pixel of each k x k block, the
// specular reflection of the indirect light divided by Ks (the lighting pass multiplies by
// Ks), times the 16-bit radiance scale.
//   mirrors (shininess >= MIRROR_SHININESS): one ray along the reflection;
//   glossy surfaces: gi.specular_rays rays from the Blinn-Phong half-vector distribution.
// Each ray's hit leaves with its emission, the lights through shadow rays (brdf.glsl's BRDF,
// as the path tracer), and the voxels' diffuse indirect light (the diffuse cones at the hit).
// A ray that leaves the scene sees the sky (black without one), the renderer's background.
// Temporal accumulation: each frame draws new directions (the seed takes the frame number,
// frame.voxel.w) and averages them with the history of the frame.voxel.z frames before it that
// saw the same view and scene (0: none, the history starts again); the renderer caps that count
// at gi.specular_history - 1, past which the average is a moving one.
#extension GL_EXT_ray_query : require
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "brdf.glsl"
#include "lights.glsl"
#include "voxel.glsl"
#include "cone_params.glsl"
#include "gbuffer_read.glsl"
#include "scene.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const uint TEXTURE_COUNT = 1;
layout(constant_id = 1) const uint SPECULAR_RAYS = 16u;  // gi.specular_rays
layout(constant_id = 2) const bool HIT_CONES = true;    // gi.rt_hit_indirect: cones, else voxel

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, std430) readonly buffer Lights { Light lights[]; };
layout(set = 0, binding = 2) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 3) uniform GiBlock { GiParams gi; };
layout(set = 0, binding = 4) uniform sampler2D g_depth;
layout(set = 0, binding = 5) uniform sampler2D g_albedo;
layout(set = 0, binding = 6) uniform sampler2D g_normal;
layout(set = 0, binding = 7) uniform sampler2D g_specular;
layout(set = 0, binding = 8) uniform sampler3D vox_lod0;
layout(set = 0, binding = 9) uniform sampler3D aniso[6];
layout(set = 0, binding = 10, r32ui) uniform readonly uimage3D brick_maps[4];
layout(set = 0, binding = 11) uniform texture3D aniso_pool[18];
layout(set = 0, binding = 12) uniform sampler pool_sampler;
layout(set = 0, binding = 13, rgba16f) uniform writeonly image2D out_specular;
layout(set = 0, binding = 14) uniform accelerationStructureEXT scene_tlas;
layout(set = 0, binding = 15, std430) readonly buffer Vertices { float vertex_data[]; };
layout(set = 0, binding = 16, std430) readonly buffer Indices { uint index_data[]; };
layout(set = 0, binding = 17, std430) readonly buffer Draws { RtDraw rt_draws[]; };
layout(set = 0, binding = 18, std430) readonly buffer Instances { Instance instances[]; };
layout(set = 0, binding = 19, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 20) uniform texture2D textures[TEXTURE_COUNT];
layout(set = 0, binding = 21) uniform sampler texture_sampler;
layout(set = 0, binding = 22) uniform sampler3D vox_direct;  // the voxels' direct radiance
// The reflections averaged over the frames the view and the scene stood still (unscaled).
layout(set = 0, binding = 23, rgba32f) uniform image2D history;
layout(set = 0, binding = 24) uniform sampler2D sky_cones;
layout(set = 0, binding = 25) uniform sampler2D sky_irradiance;
layout(set = 0, binding = 26) uniform sampler2D sky_map;
#define CONE_SKY
#include "cone.glsl"
#include "ray_query.glsl"

// Mirrors render::rays::MIRROR_SHININESS: MTL's largest exponent (McGuire's mirror uses it).
const float MIRROR_SHININESS = 1000.0;

// A PCG hash step (O'Neill 2014).
float next_random(inout uint state) {
    state = state * 747796405u + 2891336453u;
    uint w = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return float((w >> 22u) ^ w) * (1.0 / 4294967296.0);
}

// Offset along the geometric normal that keeps a ray off the surface it leaves.
float ray_offset(vec3 P) {
    return 0.01 * grid.origin.w + 1e-5 * max(abs(P.x), max(abs(P.y), abs(P.z)));
}

// The voxel GI's diffuse light leaving hit surface s: the diffuse cones from it, or its voxel's
// bounced light (bounced minus direct radiance, in the voxel the surface lies in).
vec3 hit_indirect(HitSurface s) {
    vec3 g = (s.P - grid.origin.xyz) / grid.origin.w;
    if (HIT_CONES) {
        vec4 diffuse = trace_diffuse(ConeOrigin(g, s.ns, 0.0));
        float ao = (gi.counts.w & GI_FLAG_AO) != 0u ? diffuse.a : 1.0;
        return s.albedo * max(diffuse.rgb, vec3(0.0)) * frame.radiance_scale.y * ao;
    }
    ivec3 t = radiance_texel(ivec3(floor(g - s.ng * 0.25)));
    if (t.x < 0) return vec3(0.0);
    vec3 bounced = texelFetch(vox_lod0, t, 0).rgb - texelFetch(vox_direct, t, 0).rgb;
    return max(bounced, vec3(0.0)) * frame.radiance_scale.y;
}

// Radiance leaving the hit surface s towards -d: emission, the lights, the voxel GI.
vec3 shade_hit(HitSurface s, vec3 d) {
    vec3 V = -d;
    vec3 L = s.emission;
    vec3 origin = s.P + s.ng * ray_offset(s.P);
    for (uint i = 0u; i < frame.counts.z; ++i) {
        Light l = lights[i];
        LightSample ls = sample_light(l, s.P);
        float cos_theta = dot(s.ns, ls.wi);
        if (cos_theta <= 0.0 || dot(s.ng, ls.wi) <= 0.0) continue;
        float t_max = ls.distance > 0.0 ? ls.distance : 1e30;
        if (l.shadow.x >= 0 && occluded(origin, ls.wi, t_max)) continue;
        vec3 f = brdf_diffuse(s.albedo) + brdf_specular(s.ks, s.shininess, s.ns, V, ls.wi);
        L += f * ls.irradiance * cos_theta;
    }
    return L + hit_indirect(s);
}

vec3 ray_radiance(vec3 o, vec3 d) {
    RayHit h;
    if (!trace_closest(o, d, 1e30, h)) return sky_radiance(sky_map, frame.sky, d);
    return shade_hit(hit_surface(h, o, d), d);
}

// Blinn-Phong's specular reflection of the incoming light, over Ks: E[f cos / pdf] / Ks with
// directions from the half-vector distribution (pdf (n+1)/(2 pi) cos^n / (4 V.H)), so each
// ray weighs (n+8)/(n+1) (N.L)(V.H). A mirror's lobe is one direction, H = N.
vec3 reflected(vec3 P, vec3 N, vec3 ng, vec3 V, float n, uint seed) {
    vec3 origin = P + ng * ray_offset(P);
    float norm = (n + 8.0) / (n + 1.0);
    if (n >= MIRROR_SHININESS) {
        float c = dot(N, V);
        vec3 R = reflect(-V, N);
        if (c <= 0.0 || dot(ng, R) <= 0.0) return vec3(0.0);
        return norm * c * c * ray_radiance(origin, R);
    }
    mat3 tbn = tangent_frame(N);
    vec3 sum = vec3(0.0);
    for (uint i = 0u; i < SPECULAR_RAYS; ++i) {
        float u1 = next_random(seed), u2 = next_random(seed);
        float cos_h = pow(u1, 1.0 / (n + 1.0));
        float sin_h = sqrt(max(0.0, 1.0 - cos_h * cos_h));
        float phi = 6.2831853 * u2;
        vec3 H = normalize(tbn * vec3(sin_h * cos(phi), sin_h * sin(phi), cos_h));
        vec3 L = reflect(-V, H);
        float cos_l = dot(N, L), v_h = dot(V, H);
        if (cos_l <= 0.0 || v_h <= 0.0 || dot(ng, L) <= 0.0) continue;
        sum += norm * cos_l * v_h * ray_radiance(origin, L);
    }
    return sum / float(SPECULAR_RAYS);
}

void main() {
    ivec2 lo = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(lo, imageSize(out_specular)))) return;
    int k = int(gi.counts.y);
    ivec2 px = min(lo * k + k / 2, ivec2(frame.counts.xy) - 1);
    float depth = texelFetch(g_depth, px, 0).r;
    vec4 ks_facing = texelFetch(g_specular, px, 0);
    vec3 spec = vec3(0.0);
    if (depth < 1.0 && max(ks_facing.r, max(ks_facing.g, ks_facing.b)) > 0.0) {
        vec3 P = world_position(frame, px, depth);
        vec4 ns = texelFetch(g_normal, px, 0);
        vec3 N = safe_normalize(ns.xyz, vec3(0.0, 1.0, 0.0));
        vec3 ng = oct_decode(vec2(texelFetch(g_albedo, px, 0).a, ks_facing.a));
        vec3 V = safe_normalize(frame.camera_pos.xyz - P, N);
        uint seed = (uint(lo.x) * 1973u) ^ (uint(lo.y) * 9277u) ^ 0x2545f491u ^ (frame.voxel.w * 0x9e3779b9u);
        spec = reflected(P, N, ng, V, max(ns.a, 0.0), seed);
    }
    uint past = frame.voxel.z;
    if (past > 0u) {
        vec3 h = imageLoad(history, lo).rgb;
        spec = h + (spec - h) / float(past + 1u);
    }
    imageStore(history, lo, vec4(spec, 1.0));
    imageStore(out_specular, lo, vec4(min(spec * frame.radiance_scale.x, vec3(HALF_MAX)), 1.0));
}
