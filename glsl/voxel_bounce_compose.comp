#version 460
// The bounced radiance of every occupied voxel (work list): its direct radiance (this
// update's, voxel_light.comp) plus the indirect light of its last bounce gather
// (voxel_bounce.comp). Stale voxels are zeroed beforehand (voxel_stale.comp).
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 64) in;

#define VOXEL_LIST_BINDING 0
#define VOXEL_LIST_QUALIFIER readonly
#include "voxel_list.glsl"
layout(set = 0, binding = 1, rgba16f) uniform readonly image3D vox_direct;
layout(set = 0, binding = 2, rgba16f) uniform readonly image3D vox_indirect;
layout(set = 0, binding = 3, rgba16f) uniform writeonly image3D vox_bounced;
layout(set = 0, binding = 4) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 5, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"

void main() {
    uint entry = list_invocation();
    if (entry >= vlist.occupied.count) return;
    ivec3 c = unpack_voxel(vlist.entries[entry]);
    ivec3 t = full_texel(c);
    if (t.x < 0) return;
    // The direct radiance is sampled by cones (9^3 per slot), the scratch volume is not (8^3).
    // The direct radiance is premultiplied by the voxel's cover (voxel_light.comp), the
    // gathered light is not.
    vec4 direct = imageLoad(vox_direct, radiance_texel(c));
    vec3 sum = direct.rgb + imageLoad(vox_indirect, t).rgb * direct.a;
    RADIANCE_STORE(vox_bounced, c, vec4(min(sum, vec3(HALF_MAX)), direct.a));
}
