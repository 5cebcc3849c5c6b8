#version 460
// Before re-voxelizing dynamic objects: empty the voxels the last dynamic voxelization
// filled (the list's dynamic range) and copy them to the stale list, whose radiance the next
// relight zeroes unless they are occupied again. Static voxels are never in that range.
#include "voxel.glsl"

layout(local_size_x = 64) in;

layout(constant_id = 2) const bool HAS_EMISSION = false;

layout(set = 0, binding = 0, r32ui) uniform writeonly uimage3D vox_albedo;
layout(set = 0, binding = 1, r32ui) uniform writeonly uimage3D vox_normal;
layout(set = 0, binding = 2, r32ui) uniform writeonly uimage3D vox_emission;
#define VOXEL_LIST_BINDING 3
#define VOXEL_STALE_BINDING 4
#include "voxel_list.glsl"
layout(set = 0, binding = 5) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 6, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"

void main() {
    uint i = list_invocation();
    if (i >= vlist.dynamic.count) return;
    uint e = vlist.entries[vlist.static_count + i];
    stale_entries[i] = e;
    ivec3 t = full_texel(unpack_voxel(e));
    if (t.x < 0) return;
    imageStore(vox_albedo, t, uvec4(0u));
    imageStore(vox_normal, t, uvec4(0u));
    if (HAS_EMISSION) imageStore(vox_emission, t, uvec4(0u));
}
