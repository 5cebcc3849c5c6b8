#version 460
// Voxel illumination: outgoing radiance of every occupied voxel (one invocation per entry
// of the work list, voxel_list.glsl; empty voxels keep their zero), treated as a Lambertian
// surface with the voxel's average albedo and normal:
//   L = albedo/pi * sum_lights(E * attenuation * visibility) + emission
// stored as RGBA16F (alpha = 1 where occupied), clamped below the half-float maximum.
#include "common.glsl"
#include "lights.glsl"
#define SHADOW_VIEWS_BINDING 2
#include "shadow.glsl"
#include "voxel.glsl"

layout(local_size_x = 64) in;

layout(constant_id = 0) const bool HAS_EMISSION = false;
layout(constant_id = 1) const bool NORMAL_WEIGHTED = true;
layout(constant_id = 2) const bool RAYMARCH = false;
// gi.attenuation = "per-side": write each voxel's side factors (voxel.glsl, pack_sides).
layout(constant_id = 3) const bool PER_SIDE = false;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, std430) readonly buffer Lights { Light lights[]; };
layout(set = 0, binding = 3) uniform sampler2DArrayShadow shadow_map;
layout(set = 0, binding = 4) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 5, r32ui) uniform readonly uimage3D vox_albedo;
layout(set = 0, binding = 6, r32ui) uniform readonly uimage3D vox_normal;
layout(set = 0, binding = 7, r32ui) uniform readonly uimage3D vox_emission;
layout(set = 0, binding = 8, rgba16f) uniform writeonly image3D vox_radiance;
#define VOXEL_LIST_BINDING 9
#define VOXEL_LIST_QUALIFIER readonly
#include "voxel_list.glsl"
layout(set = 0, binding = 10, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"
layout(set = 0, binding = 11, r32ui) uniform writeonly uimage3D vox_sides;
layout(set = 0, binding = 12, rgba32ui) uniform readonly uimage3D vox_side_normals;

layout(push_constant) uniform Push { float softness; } pc;

bool occupied(ivec3 c) {
    ivec3 t = full_texel(c);
    return t.x >= 0 && (imageLoad(vox_albedo, t).r >> 24) != 0u;
}

// Trilinear occupancy at grid position g (voxel units).
float occupancy(vec3 g) {
    vec3 f = g - 0.5;
    ivec3 b = ivec3(floor(f));
    vec3 w = f - vec3(b);
    float o = 0.0;
    for (int i = 0; i < 8; ++i) {
        ivec3 d = ivec3(i & 1, (i >> 1) & 1, i >> 2);
        vec3 wd = mix(1.0 - w, w, vec3(d));
        o += (occupied(b + d) ? 1.0 : 0.0) * wd.x * wd.y * wd.z;
    }
    return o;
}

// Visibility of the light along wi from grid position g over `dist` voxels: hard (any
// occupied voxel blocks) or soft (occlusion accumulated with weight softness / distance).
// The caller starts g off the surface (along the normal) so grazing rays do not run inside
// the surface's own voxel layer.
float raymarch_visibility(vec3 g, vec3 wi, float dist) {
    float occlusion = 0.0;
    float t = 0.5;
    float res = float(grid.dims.x);
    float tmax = min(dist, 2.0 * res);
    while (t < tmax && occlusion < 1.0) {
        vec3 p = g + wi * t;
        if (any(lessThan(p, vec3(0.0))) || any(greaterThan(p, vec3(res)))) break;
        if (pc.softness <= 0.0) {
            if (occupied(ivec3(floor(p)))) return 0.0;
        } else {
            occlusion += (1.0 - occlusion) * occupancy(p) * min(pc.softness / t, 1.0);
        }
        t += 0.5;
    }
    return clamp(1.0 - occlusion, 0.0, 1.0);
}

float attenuation(vec3 n_avg, vec3 wi) {
    if (NORMAL_WEIGHTED) {
        // Each axis-aligned face of the voxel that faces the light receives cos = |wi.axis|,
        // weighted by how much of the average normal points that way.
        vec3 nn = safe_normalize(n_avg, vec3(0.0));
        vec3 w = nn * nn;
        vec3 c = max(wi * sign(nn), 0.0);
        return dot(w, c);
    }
    return max(dot(safe_normalize(n_avg, vec3(0.0)), wi), 0.0);
}

void main() {
    uint entry = list_invocation();
    if (entry >= vlist.occupied.count) return;
    ivec3 c = unpack_voxel(vlist.entries[entry]);
    ivec3 t = full_texel(c);
    if (t.x < 0) return;
    uint a = imageLoad(vox_albedo, t).r;
    vec3 albedo = unpack_rgb_count(a).rgb / 255.0;
    vec4 normal_word = unpack_rgb_count(imageLoad(vox_normal, t).r) / 255.0;
    vec3 n_avg = normal_word.rgb * 2.0 - 1.0;
    vec3 N = safe_normalize(n_avg, vec3(0.0, 1.0, 0.0));
    float voxel = grid.origin.w;
    vec3 center = grid.origin.xyz + (vec3(c) + 0.5) * voxel;
    // The surface in the voxel (voxel.glsl, SUM_OFFSET): where shadow maps are read, as the
    // G-buffer reads them for the pixels on that surface.
    vec3 surface = center + N * (decode_surface_offset(normal_word.a) * voxel);
    vec3 irradiance = vec3(0.0);
    // With PER_SIDE, a voxel whose faces face different ways also sums, by luminance, the
    // light its mean normal receives and the light its faces seen from each side receive
    // (voxel.glsl, side_normal).
    bool faces_differ = PER_SIDE && length(n_avg) < ONE_PLANE;
    float mean_light = 0.0;
    float side_light[6] = float[6](0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    vec3 side_n[6];
    if (faces_differ) {
        uvec4 packed = imageLoad(vox_side_normals, t);
        for (int j = 0; j < 6; ++j) side_n[j] = side_normal(packed, j);
    }
    for (uint i = 0u; i < frame.counts.z; ++i) {
        Light l = lights[i];
        // Not nearer than half a voxel: a voxel stands for its whole extent, over which the
        // irradiance of a light inside it averages to a finite value.
        LightSample s = sample_light_near(l, surface, 0.5 * voxel);
        float att = attenuation(n_avg, s.wi);
        if ((att <= 0.0 && !faces_differ) || max(s.irradiance.r, max(s.irradiance.g, s.irradiance.b)) <= 0.0) continue;
        float vis = 1.0;
        if (RAYMARCH) {
            vec3 g = (center - grid.origin.xyz) / voxel + N * 1.5;
            float dist = s.distance > 0.0 ? s.distance / voxel - 1.5 : 1e30;
            vis = raymarch_visibility(g, s.wi, dist);
        } else if (l.shadow.x >= 0) {
            vec3 P = surface;
            int layer = shadow_view_index(l, P, frame.shadow.x + 1.5 * frame.shadow.y + 2.0, frame.shadow.z);
            vis = shadow_visibility(shadow_map, views[layer], layer, P, N, s.wi, s.distance,
                                    frame.shadow.x, frame.shadow.y, frame.shadow.z);
        }
        irradiance += s.irradiance * att * vis;
        if (faces_differ) {
            float e = luminance(s.irradiance) * vis;
            mean_light += e * att;
            for (int j = 0; j < 6; ++j) side_light[j] += e * max(dot(side_n[j], s.wi), 0.0);
        }
    }
    if (PER_SIDE) {
        // Where the mean normal gets no light there is no radiance to share out: 1 everywhere.
        float k[6];
        for (int j = 0; j < 6; ++j) k[j] = faces_differ && mean_light > 0.0 ? side_light[j] / mean_light : 1.0;
        imageStore(vox_sides, t, uvec4(pack_sides(k)));
    }
    vec3 radiance = albedo * INV_PI * irradiance;
    if (HAS_EMISSION) {
        radiance += unpack_rgb_count(imageLoad(vox_emission, t).r).rgb / 255.0 * grid.params.x;
    }
    // Premultiplied by how much of the voxel its surfaces cover (voxel.glsl, AREA_COVER).
    float cover = AREA_COVER ? albedo_cover(a) : 1.0;
    RADIANCE_STORE(vox_radiance, c, vec4(min(radiance * grid.params.y, vec3(HALF_MAX)) * cover, cover));
}
