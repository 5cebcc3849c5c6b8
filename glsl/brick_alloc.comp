#version 460
// The resident bricks of each pool (bricks.glsl, brick_list.glsl), one mode per dispatch:
//   COUNT (pool POOL, one workgroup per block of 512 map entries in grid order): how many
//     bricks the mark pass set to pending, into the scan buffer (scan_buffer.glsl).
//   ALLOCATE (the same workgroups, after scan.comp made the counts offsets): every pending
//     brick gets the next slot of the pool in grid order and joins the pool's list, so a
//     brick's slot, and with it where its texels lie in the pool, is the same on every run,
//     whatever order the marks came in.
//   FINALIZE (one invocation): each pool's list grows by the bricks allocated, and its
//     indirect dispatches, over all its resident bricks and over its dynamic ones (the list
//     past the static bricks); after the static voxelization (STATIC) the bricks so far are
//     the static ones.
//   RELEASE (pool POOL, per map entry): before the dynamic objects are revoxelized, every
//     dynamic brick leaves the map (it reads as empty) unless the marking run claims it again.
//   RESTART (one invocation): each pool's list ends at its static bricks again, so the
//     allocation after the marking run hands the dynamic slots out anew.
// Static bricks keep their slots from the static voxelization on; the capacities bound the
// static bricks plus what dynamic objects can touch at once (render::bricks::capacity).
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

#define ALLOCATE 0
#define FINALIZE 1
#define RELEASE 2
#define RESTART 3
#define COUNT 4
layout(constant_id = 0) const int POOL = 0;
layout(constant_id = 1) const int MODE = ALLOCATE;
layout(constant_id = 2) const bool STATIC = false;
// COUNT, ALLOCATE: the first word of this pool's block counts in the scan buffer.
layout(constant_id = 3) const uint SCAN_FIRST = 0u;

layout(set = 0, binding = 0) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 1, r32ui) uniform uimage3D brick_maps[4];
#define BRICK_MAPS_WRITABLE
#include "bricks.glsl"
#define BRICK_LIST_BINDING 2
#include "brick_list.glsl"
#define SCAN_BINDING 3
#include "scan_buffer.glsl"
#include "workgroup_scan.glsl"

void set_range(inout BrickRange r, uint n) {
    r.count = n;
    r.groups_x = min(n, BRICK_GROUPS_X);
    r.groups_y = 8u * ((n + BRICK_GROUPS_X - 1u) / BRICK_GROUPS_X);
    r.groups_z = 1u;
}

void finalize() {
    for (int p = 0; p < 4; ++p) {
        uint n = min(blist.ranges[p].count + scan.words[SCAN_POOL_TOTAL + uint(p)], blist.capacity[p]);
        if (STATIC) blist.static_count[p] = n;
        set_range(blist.ranges[p], n);
        set_range(blist.dynamic_ranges[p], n - blist.static_count[p]);
    }
}

// Map entry e of the pool's map, in grid order (x fastest).
ivec3 map_entry(uint e) {
    uint side = grid.pools[POOL].w;
    return ivec3(e % side, (e / side) % side, e / (side * side));
}

// COUNT and ALLOCATE: this invocation's 8 map entries of the workgroup's block.
void count_or_allocate() {
    uint side = grid.pools[POOL].w;
    uint first = gl_WorkGroupID.x * SCAN_BLOCK + gl_LocalInvocationIndex * 8u;
    uint pending = 0u;
    for (uint k = 0u; k < 8u; ++k) {
        uint e = first + k;
        if (e < side * side * side && brick_map_load(POOL, map_entry(e)) == BRICK_PENDING) pending |= 1u << k;
    }
    uint total;
    uint before = workgroup_exclusive_scan(uint(bitCount(pending)), total);
    if (MODE == COUNT) {
        if (gl_LocalInvocationIndex == 0u) scan.words[SCAN_FIRST + gl_WorkGroupID.x] = total;
        return;
    }
    // The list's length is only advanced by FINALIZE, after every slot is handed out.
    uint s = blist.ranges[POOL].count + scan.words[SCAN_FIRST + gl_WorkGroupID.x] + before;
    for (uint k = 0u; k < 8u; ++k) {
        if ((pending & (1u << k)) == 0u) continue;
        ivec3 b = map_entry(first + k);
        if (s < blist.capacity[POOL]) {
            blist.entries[blist.first[POOL] + s] = pack_brick(b);
            brick_map_store(POOL, b, slot_entry(POOL, s));
        } else {
            atomicAdd(blist.dropped[POOL], 1u);
            brick_map_store(POOL, b, 0u);
        }
        ++s;
    }
}

void release(ivec3 b) {
    uint e = brick_map_load(POOL, b);
    if (e != 0u && e != BRICK_PENDING && entry_slot(POOL, e) >= blist.static_count[POOL]) brick_map_store(POOL, b, 0u);
}

void main() {
    if (MODE == FINALIZE || MODE == RESTART) {
        if (gl_GlobalInvocationID != uvec3(0)) return;
        if (MODE == FINALIZE) {
            finalize();
        } else {
            for (int p = 0; p < 4; ++p) blist.ranges[p].count = blist.static_count[p];
        }
        return;
    }
    if (MODE == COUNT || MODE == ALLOCATE) {
        count_or_allocate();
        return;
    }
    ivec3 b = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(b, ivec3(int(grid.pools[POOL].w))))) return;
    release(b);
}
