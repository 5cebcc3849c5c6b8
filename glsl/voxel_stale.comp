#version 460
// Zero one radiance volume at the stale voxels (emptied by the last dynamic clear) that are
// still empty, before a list-driven pass writes the occupied ones: together they write every
// voxel whose value can have changed, as a pass over the whole grid would.
#include "voxel.glsl"

layout(local_size_x = 64) in;

#define VOXEL_LIST_BINDING 0
#define VOXEL_STALE_BINDING 1
#define VOXEL_LIST_QUALIFIER readonly
#include "voxel_list.glsl"
layout(set = 0, binding = 2, r32ui) uniform readonly uimage3D vox_albedo;
layout(set = 0, binding = 3, rgba16f) uniform writeonly image3D vox_target;
layout(set = 0, binding = 4) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 5, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"

void main() {
    uint i = list_invocation();
    if (i >= vlist.stale.count) return;
    ivec3 c = unpack_voxel(stale_entries[i]);
    ivec3 t = full_texel(c);
    if (t.x >= 0 && (imageLoad(vox_albedo, t).r >> 24) != 0u) return;
    // Also where its brick is no longer resident: the apron copies above it may be.
    RADIANCE_STORE(vox_target, c, vec4(0.0));
}
