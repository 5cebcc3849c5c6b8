#version 460
// One level of the six directional (anisotropic) radiance volumes. Each texel covers a 2x2x2
// block of the level below (the full-resolution radiance volume for level 0); for the
// volume of direction +x the block's front voxel along x is composited over its back voxel
// (premultiplied "over": c = c_front + (1 - a_front) c_back) for each of the four rows, and
// the four rows are averaged. Same for -x (front = high x), +y, -y, +z, -z. Texels are stored
// as (L * tau, tau) for trilinear cone samples, or premultiplied (c, alpha) for two-tap ones
// (TWO_TAP; voxel.glsl); the full-resolution volume holds (L, occupancy 0 or 1), which is
// premultiplied already; with gi.voxel_cover = "directional" level 0 weighs each voxel by how
// much of its surface faces the volume's axis, and with gi.plane_backs = "dark" a voxel that
// holds one plane shows the volumes that see it from behind its emission only, or with
// "closed" nothing where that back closes a solid (voxel_backs.comp; seen_from). With
// bricked volumes (bricks.glsl) a pooled level is written brick by brick over its resident
// bricks (indirect), and read through its map.
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

// Level 0 reads the full-resolution volume (bound in every slot of `src`); higher levels
// read the previous level of each directional volume.
layout(constant_id = 0) const bool FROM_FULL = true;
// The pool the source level is in (0: a dense level) and the pool written (0: dense, every
// texel; else the pool's resident bricks).
layout(constant_id = 1) const int SRC_POOL = 0;
layout(constant_id = 2) const int DST_POOL = 0;
// gi.cone_filter = "two-tap": texels hold opacity rather than optical depth.
layout(constant_id = 3) const bool TWO_TAP = false;
// gi.opacity = "layers": an opaque texel holds optical depth LAYER_TAU (voxel.glsl).
layout(constant_id = 4) const bool LAYERS = false;
// gi.attenuation = "per-side": level 0 shows each side of a full-resolution voxel its side
// factor times its radiance (voxel_light.comp, pack_sides in voxel.glsl).
layout(constant_id = 5) const bool PER_SIDE = false;
// gi.plane_backs = "dark": level 0 shows a one-plane voxel's back its emission only.
layout(constant_id = 6) const bool DARK_BACKS = false;
// Some material emits (the emission volume is bound; else the albedo volume stands in).
layout(constant_id = 7) const bool HAS_EMISSION = false;
// gi.plane_backs = "closed" (with DARK_BACKS): level 0 leaves out the backs that close a solid.
layout(constant_id = 8) const bool CLOSED_BACKS = false;

vec4 stored(vec4 premultiplied) {
    return TWO_TAP ? premultiplied : tau_from_alpha(premultiplied, LAYERS ? LAYER_TAU : VOXEL_TAU);
}

vec4 premultiplied(vec4 texel) {
    return TWO_TAP ? texel : alpha_from_tau(texel);
}

layout(set = 0, binding = 0, rgba16f) uniform readonly image3D src[6];
layout(set = 0, binding = 1, rgba16f) uniform writeonly image3D dst[6];
layout(set = 0, binding = 2) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 3, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"
#define BRICK_LIST_BINDING 4
#define BRICK_LIST_QUALIFIER readonly
#include "brick_list.glsl"
// The full-resolution normal volume (voxel.glsl; read by level 0 with DIRECTIONAL_COVER).
layout(set = 0, binding = 5, r32ui) uniform readonly uimage3D vox_normal;
// The voxel light's side factors (read by level 0 with PER_SIDE).
layout(set = 0, binding = 6, r32ui) uniform readonly uimage3D vox_sides;
// The voxels' emission (read by level 0 with DARK_BACKS and HAS_EMISSION).
layout(set = 0, binding = 7, r32ui) uniform readonly uimage3D vox_emission;
// The backs that close a solid, a bit per directional volume (read by level 0 with
// CLOSED_BACKS; voxel_backs.comp).
layout(set = 0, binding = 8, r8ui) uniform readonly uimage3D vox_backs;

vec4 over(vec4 front, vec4 back) {
    return front + (1.0 - clamp(front.a, 0.0, 1.0)) * back;
}

// Where texel C of the source level is stored; (-1) when it is empty (not resident).
ivec3 src_texel(ivec3 C) {
    if (FROM_FULL) return radiance_texel(C);
    return SRC_POOL == 0 ? C : level_texel(SRC_POOL, C);
}

// Every face reads the same 2x2x2 block of the level below, stored at the same places in
// each face's image: where, found once (from the full-resolution volume, also what).
ivec3 block_texel[8];
vec4 full_block[8];
// With DIRECTIONAL_COVER, each full-resolution voxel's share seen along x, y, z.
vec3 block_share[8];
// With PER_SIDE, each full-resolution voxel's side factors.
uint block_sides[8];
// With DARK_BACKS, each full-resolution voxel's plane_normal (front_share) and its emitted
// radiance, premultiplied as the radiance volume is; with CLOSED_BACKS, its backs that close a
// solid (a bit per face).
vec3 block_normal[8];
vec3 block_emitted[8];
uint block_closed[8];

void find_block(ivec3 base) {
    for (int i = 0; i < 8; ++i) {
        ivec3 c = base + ivec3(i & 1, (i >> 1) & 1, i >> 2);
        block_texel[i] = src_texel(c);
        block_share[i] = vec3(1.0);
        block_sides[i] = 0u;
        if (!FROM_FULL) continue;
        full_block[i] = block_texel[i].x < 0 ? vec4(0.0) : imageLoad(src[0], block_texel[i]);
        if (PER_SIDE && full_block[i].a > 0.0) block_sides[i] = imageLoad(vox_sides, full_texel(c)).r;
        vec3 n = vec3(0.0);
        if ((DIRECTIONAL_COVER || DARK_BACKS) && full_block[i].a > 0.0)
            n = unpack_rgb_count(imageLoad(vox_normal, full_texel(c)).r).rgb / 255.0 * 2.0 - 1.0;
        if (DIRECTIONAL_COVER && full_block[i].a > 0.0)
            block_share[i] = vec3(directional_share(n, 0), directional_share(n, 1), directional_share(n, 2));
        if (DARK_BACKS) {
            block_normal[i] = plane_normal(n);
            // As voxel_light.comp stores it: scaled, clamped, premultiplied by the cover.
            vec3 e = HAS_EMISSION && full_block[i].a > 0.0
                       ? unpack_rgb_count(imageLoad(vox_emission, full_texel(c)).r).rgb / 255.0 * grid.params.x : vec3(0.0);
            block_emitted[i] = min(e * grid.params.y, vec3(HALF_MAX)) * full_block[i].a;
            block_closed[i] = CLOSED_BACKS && full_block[i].a > 0.0 ? imageLoad(vox_backs, full_texel(c)).r : 0u;
        }
    }
}

// Voxel i of the block as the volume of direction `face` sees it: with DIRECTIONAL_COVER, its
// cover along that axis (directional_share), radiance premultiplied; with PER_SIDE, the light
// of its side that faces the cones (those travelling +x meet the faces toward -x: side
// face ^ 1); with DARK_BACKS, from behind its plane its emission only (two-sided, as the path
// tracer's), its reflected and bounced light being its front's; with CLOSED_BACKS, where that
// back closes a solid, nothing of the back (what a cone's rays meet there, they met at its front).
vec4 seen_from(vec4 v, int i, int face) {
    vec4 seen = DIRECTIONAL_COVER ? v * block_share[i][face / 2] : v;
    if (PER_SIDE) seen.rgb *= side_factor(block_sides[i], face ^ 1);
    if (DARK_BACKS) {
        float front = front_share(block_normal[i], face ^ 1);
        if (((block_closed[i] >> face) & 1u) != 0u) return seen * front;
        vec3 emitted = min(block_emitted[i] * (seen.a / max(v.a, 1e-6)), seen.rgb);
        seen.rgb = mix(emitted, seen.rgb, front);
    }
    return seen;
}

// Literal indices only: arrays of storage images are not indexed dynamically.
#define LOAD(FACE, C) load_##FACE(C)
#define DEFINE_LOAD(FACE)                                                             \
    vec4 load_##FACE(ivec3 C) {                                                       \
        ivec3 o = C & 1;                                                              \
        int i = o.x + 2 * o.y + 4 * o.z;                                              \
        if (FROM_FULL) return seen_from(full_block[i], i, FACE);                      \
        ivec3 t = block_texel[i];                                                     \
        return t.x < 0 ? vec4(0.0) : premultiplied(imageLoad(src[FACE], t));         \
    }
DEFINE_LOAD(0)
DEFINE_LOAD(1)
DEFINE_LOAD(2)
DEFINE_LOAD(3)
DEFINE_LOAD(4)
DEFINE_LOAD(5)

#define INTEGRATE(FACE, AXIS, FRONT)                                              \
    {                                                                             \
        vec4 acc = vec4(0.0);                                                     \
        for (int u = 0; u < 2; ++u) {                                             \
            for (int v = 0; v < 2; ++v) {                                         \
                ivec3 o = AXIS == 0 ? ivec3(0, u, v) : (AXIS == 1 ? ivec3(u, 0, v) : ivec3(u, v, 0)); \
                ivec3 a = ivec3(0); a[AXIS] = 1;                                  \
                ivec3 front = base + o + a * FRONT;                               \
                ivec3 back = base + o + a * (1 - FRONT);                          \
                acc += over(LOAD(FACE, front), LOAD(FACE, back));                 \
            }                                                                     \
        }                                                                         \
        imageStore(dst[FACE], store_at, min(stored(acc * 0.25), vec4(HALF_MAX)));         \
    }

void main() {
    ivec3 c, store_at;
    if (DST_POOL == 0) {
        c = ivec3(gl_GlobalInvocationID);
        if (any(greaterThanEqual(c, imageSize(dst[0])))) return;
        store_at = c;
    } else {
        uint i = brick_dispatch_index(DST_POOL);
        if (i == ~0u) return;
        ivec3 b = unpack_brick(blist.entries[blist.first[DST_POOL] + i]);
        uint block = gl_WorkGroupID.y % 8u;
        c = b * 8 + ivec3(block & 1u, (block >> 1) & 1u, block >> 2) * 4 + ivec3(gl_LocalInvocationID);
        store_at = level_texel(DST_POOL, c);  // the apron brick past the last texel has none
        if (store_at.x < 0) return;
    }
    ivec3 base = c * 2;
    find_block(base);
    INTEGRATE(0, 0, 0)  // +x: cones travelling +x meet low x first
    INTEGRATE(1, 0, 1)  // -x
    INTEGRATE(2, 1, 0)  // +y
    INTEGRATE(3, 1, 1)  // -y
    INTEGRATE(4, 2, 0)  // +z
    INTEGRATE(5, 2, 1)  // -z
}
