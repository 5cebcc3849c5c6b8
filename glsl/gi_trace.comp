#version 460
// Per-pixel cone tracing from the G-buffer, at 1/k of the image resolution (each traced pixel
// takes the centre pixel of its k x k block):
//   diffuse:  rgb = cosine-weighted mean incoming radiance (irradiance / pi), a = AO factor
//   specular: rgb = radiance along the mirror direction, cone from the Blinn-Phong exponent
//   shadow:   visibility of lights 0..3 through a cone toward each (soft shadows)
#include "common.glsl"
#include "lights.glsl"
#include "voxel.glsl"
#include "grid_ray.glsl"
#include "cone_params.glsl"
#include "gbuffer_read.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const bool HAS_SPECULAR = false;
layout(constant_id = 1) const bool CONE_SHADOWS = false;
// gi.diffuse_rays: > 0 replaces the diffuse cones by this many rays (a diagnostic). A
// specialization constant: the ordinary pipeline has no trace of it.
layout(constant_id = 2) const uint DIFFUSE_RAYS = 0u;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, std430) readonly buffer Lights { Light lights[]; };
layout(set = 0, binding = 2) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 3) uniform GiBlock { GiParams gi; };
layout(set = 0, binding = 4) uniform sampler2D g_depth;
layout(set = 0, binding = 5) uniform sampler2D g_normal;
layout(set = 0, binding = 6) uniform sampler2D g_specular;
layout(set = 0, binding = 7) uniform sampler3D vox_lod0;
layout(set = 0, binding = 8) uniform sampler3D aniso[6];
layout(set = 0, binding = 9, rgba16f) uniform writeonly image2D out_diffuse;
layout(set = 0, binding = 10, rgba16f) uniform writeonly image2D out_specular;
layout(set = 0, binding = 11, rgba8) uniform writeonly image2D out_shadow;
layout(set = 0, binding = 12, r32ui) uniform readonly uimage3D brick_maps[4];
layout(set = 0, binding = 13) uniform texture3D aniso_pool[18];
layout(set = 0, binding = 14) uniform sampler pool_sampler;
layout(set = 0, binding = 15) uniform sampler2D sky_cones;
layout(set = 0, binding = 16) uniform sampler2D sky_irradiance;
#define CONE_SKY
#include "cone.glsl"

// Half aperture of the specular cone for Blinn-Phong exponent n: the cone holding half the
// energy of the equivalent Phong lobe (exponent n/4, energy within angle a of the mirror
// direction 1 - cos^(n/4+1) a), clamped to 0.25..85 degrees.
float specular_tan_half(float n) {
    float a = acos(pow(0.5, 1.0 / (max(n, 0.0) / 4.0 + 1.0)));
    return tan(clamp(a, radians(0.25), radians(85.0)));
}

// A PCG hash step (O'Neill 2014), for the diagnostic ray gather.
float next_random(inout uint state) {
    state = state * 747796405u + 2891336453u;
    uint w = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return float((w >> 22u) ^ w) * (1.0 / 4294967296.0);
}

// Radiance of the first occupied voxel along a ray from g (voxel units) through the
// full-resolution volume; the sky (its sharpest cone level) when the ray leaves the grid.
vec3 first_voxel_radiance(vec3 g, vec3 d) {
    int res = int(grid.dims.x);
    VoxelWalk w = voxel_walk(g, d);
    vec3 sky = sky_cone(sky_cones, frame.sky, d, 0.0) * grid.params.y;
    if (any(lessThan(w.c, ivec3(0))) || any(greaterThanEqual(w.c, ivec3(res)))) return sky;
    // Voxels hold premultiplied (L * cover, cover) (voxel.glsl): composited front to back.
    vec3 seen = vec3(0.0);
    float through = 1.0;
    for (int i = 0; i < 3 * 512; ++i) {
        ivec3 t = radiance_texel(w.c);
        vec4 v = t.x < 0 ? vec4(0.0) : texelFetch(vox_lod0, t, 0);
        if (v.a > 0.0) {
            seen += through * v.rgb;
            through *= 1.0 - clamp(v.a, 0.0, 1.0);
            if (through <= 0.0) return seen;
        }
        if (!voxel_walk_step(w, res)) return seen + through * sky;
    }
    return seen;
}

// The diagnostic alternative to the diffuse cones (gi.diffuse_rays = n): the mean radiance of
// n cosine-distributed rays through the full-resolution voxels, each to its first occupied
// voxel. It starts past every voxel the surface touches (|n|_1 off it, plus RAY_MARGIN) and is
// exact for the voxelized scene up to noise, so it separates the voxels' error from the cones'.
// The margin covers the surface point's error as read back from the depth buffer: a face on a
// voxel boundary lies in the voxel on its positive side, and a point read a hair below it
// starts inside that voxel and sees the surface's own light. With a margin of 1e-3 voxels the
// floor of scenes/leak/corner.toml at 256^3 (near plane 1 cm, far 1 km) got bands of its own
// light, twice its indirect light; 0.01 was enough there (tests/gi_truth.rs,
// rays_through_the_voxels_do_not_see_their_own_floor).
const float RAY_MARGIN = 0.05;
vec3 ray_gather(ConeOrigin o, uint n, uint seed) {
    mat3 tbn = tangent_frame(o.n);
    vec3 g = o.p + o.n * (abs(o.n.x) + abs(o.n.y) + abs(o.n.z) + RAY_MARGIN);
    vec3 sum = vec3(0.0);
    // llvmpipe stops loops after 65535 iterations per invocation, across all of them: keep
    // rays x (longest walk, 3 res) below that.
    n = max(min(n, 60000u / (3u * grid.dims.x)), 1u);
    for (uint i = 0u; i < n; ++i) {
        float u1 = next_random(seed), u2 = next_random(seed);
        float r = sqrt(u1), phi = 6.2831853 * u2;
        vec3 d = normalize(tbn * vec3(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u1))));
        sum += first_voxel_radiance(g, d);
    }
    return sum / float(n);
}

void main() {
    ivec2 lo = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(lo, imageSize(out_diffuse)))) return;
    int k = int(gi.counts.y);
    ivec2 px = min(lo * k + k / 2, ivec2(frame.counts.xy) - 1);
    float depth = texelFetch(g_depth, px, 0).r;
    if (depth >= 1.0) {
        imageStore(out_diffuse, lo, vec4(0.0, 0.0, 0.0, 1.0));
        if (HAS_SPECULAR) imageStore(out_specular, lo, vec4(0.0));
        if (CONE_SHADOWS) imageStore(out_shadow, lo, vec4(1.0));
        return;
    }
    vec3 P = world_position(frame, px, depth);
    vec4 ns = texelFetch(g_normal, px, 0);
    vec3 N = safe_normalize(ns.xyz, vec3(0.0, 1.0, 0.0));
    float voxel = grid.origin.w;
    ConeOrigin o = ConeOrigin((P - grid.origin.xyz) / voxel, N, 0.0);

    vec4 diffuse;
    if (DIFFUSE_RAYS > 0u) {
        uint seed = (uint(lo.x) * 1973u) ^ (uint(lo.y) * 9277u) ^ 0x9e3779b9u;
        diffuse = vec4(ray_gather(o, DIFFUSE_RAYS, seed), 1.0);
    } else {
        diffuse = trace_diffuse(o);
    }
    if ((gi.counts.w & GI_FLAG_AO) == 0u) diffuse.a = 1.0;
    imageStore(out_diffuse, lo, diffuse);

    if (HAS_SPECULAR) {
        vec3 ks = texelFetch(g_specular, px, 0).rgb;
        vec3 spec = vec3(0.0);
        if (max(ks.r, max(ks.g, ks.b)) > 0.0) {
            vec3 V = safe_normalize(frame.camera_pos.xyz - P, N);
            vec3 R = reflect(-V, N);
            float tan_half = specular_tan_half(ns.a);
            ConeResult c = trace_cone(o, R, tan_half, 1e30);
            spec = min(c.radiance + cone_sky(c, R, tan_half), vec3(HALF_MAX));
        }
        imageStore(out_specular, lo, vec4(spec, 1.0));
    }

    if (CONE_SHADOWS) {
        vec4 vis = vec4(1.0);
        for (uint i = 0u; i < min(frame.counts.z, 4u); ++i) {
            Light l = lights[i];
            if (l.shadow.x < 0) continue;
            LightSample s = sample_light(l, P);
            if (dot(s.wi, N) <= 0.0) continue;
            // Up to the light (the tracer keeps even grazing cones off the surface's voxels).
            float dist = s.distance > 0.0 ? s.distance / voxel : 1e30;
            vis[i] = 1.0 - trace_cone(o, s.wi, gi.shadow.x, dist).opacity;
        }
        imageStore(out_shadow, lo, vis);
    }
}
