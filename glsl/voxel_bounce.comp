#version 460
// One light bounce in the voxels: occupied voxels (one invocation per entry of the work list,
// voxel_list.glsl) trace the diffuse cones over their normal's hemisphere through the current
// radiance (full-resolution volume + directional mips) and store the light they reflect:
//   L_indirect = albedo/pi * E,   E = pi * sum_i w_i L_i   =>   L_indirect = albedo * sum_i w_i L_i
// voxel_bounce_compose.comp then adds it to the direct radiance. Cones that leave the scene
// gather the sky (cone.glsl), so the voxels hold sky light and it bounces. With an interleave N > 1
// (frame.voxel.y) only one in N workgroups of static voxels gathers this update, in turn;
// the others keep the indirect light of their last gather. Dynamic voxels, new at every
// revoxelization, gather every update.
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0) uniform GridBlock { VoxelGrid grid; };
#include "cone_params.glsl"
layout(set = 0, binding = 1) uniform GiBlock { GiParams gi; };
layout(set = 0, binding = 2) uniform sampler3D vox_lod0;
layout(set = 0, binding = 3) uniform sampler3D aniso[6];
layout(set = 0, binding = 4, r32ui) uniform readonly uimage3D vox_albedo;
layout(set = 0, binding = 5, r32ui) uniform readonly uimage3D vox_normal;
layout(set = 0, binding = 6) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 7, rgba16f) uniform writeonly image3D vox_indirect;
#define VOXEL_LIST_BINDING 8
#define VOXEL_LIST_QUALIFIER readonly
#include "voxel_list.glsl"
layout(set = 0, binding = 9, r32ui) uniform readonly uimage3D brick_maps[4];
layout(set = 0, binding = 10) uniform texture3D aniso_pool[18];
layout(set = 0, binding = 11) uniform sampler pool_sampler;
layout(set = 0, binding = 12) uniform sampler2D sky_cones;
layout(set = 0, binding = 13) uniform sampler2D sky_irradiance;
#define CONE_SKY
#include "cone.glsl"

void main() {
    uint entry = list_invocation();
    if (entry >= vlist.occupied.count) return;
    // Whole workgroups take turns (not every N-th invocation, which would leave each SIMD
    // batch as busy as without interleave).
    uint interleave = max(frame.voxel.y, 1u);
    uint turn = (entry / VOXEL_LIST_GROUP) % interleave;
    if (entry < vlist.static_count && turn != frame.voxel.x % interleave) return;
    ivec3 c = unpack_voxel(vlist.entries[entry]);
    ivec3 t = full_texel(c);
    if (t.x < 0) return;
    uint a = imageLoad(vox_albedo, t).r;
    vec3 albedo = unpack_rgb_count(a).rgb / 255.0;
    vec3 n_avg = unpack_rgb_count(imageLoad(vox_normal, t).r).rgb / 255.0 * 2.0 - 1.0;
    vec3 N = safe_normalize(n_avg, vec3(0.0, 1.0, 0.0));
    vec4 d = trace_diffuse(ConeOrigin(vec3(c) + 0.5, N, 0.5));
    // The scratch volume is read texel by texel (voxel_bounce_compose.comp): 8^3 per slot.
    imageStore(vox_indirect, t, vec4(min(albedo * d.rgb, vec3(HALF_MAX)), 1.0));
}
