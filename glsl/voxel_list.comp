#version 460
// The work list's bookkeeping between the passes that append to it and those that dispatch
// over it (one invocation): counts clamped to the capacity and the indirect group counts of
// each range (voxel_list.glsl).
//   STATIC  after static voxelization: every voxel so far is static; no dynamic, none stale.
//   DYNAMIC after dynamic voxelization: the entries past static_count are the dynamic voxels.
//   CLEARED after the dynamic clear copied the dynamic voxels to the stale list and emptied
//           them: they become the stale range and the list shrinks back to the static voxels.
layout(local_size_x = 1) in;

#define VOXEL_LIST_BINDING 0
#include "voxel_list.glsl"

const uint STATIC = 0u;
const uint DYNAMIC = 1u;
const uint CLEARED = 2u;

layout(push_constant) uniform Push { uint mode; } pc;

void main() {
    uint count = min(vlist.occupied.count, uint(vlist.entries.length()));
    if (pc.mode == STATIC) {
        vlist.static_count = count;
        vlist.occupied = list_range(count);
        vlist.dynamic = list_range(0u);
        vlist.stale = list_range(0u);
    } else if (pc.mode == DYNAMIC) {
        vlist.occupied = list_range(count);
        vlist.dynamic = list_range(count - min(vlist.static_count, count));
    } else {
        vlist.stale = list_range(vlist.dynamic.count);
        vlist.occupied = list_range(vlist.static_count);
        vlist.dynamic = list_range(0u);
    }
}
