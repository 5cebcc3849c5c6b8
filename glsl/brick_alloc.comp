#version 460
// The resident bricks of each pool (bricks.glsl, brick_list.glsl), one mode per dispatch:
//   ALLOCATE (pool POOL, one invocation per map entry): every brick the mark pass set to
//     pending gets the next slot of the pool and joins the pool's list.
//   FINALIZE (one invocation): each pool's indirect dispatches, over all its resident bricks
//     and over its dynamic ones (the list past the static bricks); after the static
//     voxelization (STATIC) the bricks so far are the static ones.
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
layout(constant_id = 0) const int POOL = 0;
layout(constant_id = 1) const int MODE = ALLOCATE;
layout(constant_id = 2) const bool STATIC = false;

layout(set = 0, binding = 0) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 1, r32ui) uniform uimage3D brick_maps[4];
#define BRICK_MAPS_WRITABLE
#include "bricks.glsl"
#define BRICK_LIST_BINDING 2
#include "brick_list.glsl"

void set_range(inout BrickRange r, uint n) {
    r.count = n;
    r.groups_x = min(n, BRICK_GROUPS_X);
    r.groups_y = 8u * ((n + BRICK_GROUPS_X - 1u) / BRICK_GROUPS_X);
    r.groups_z = 1u;
}

void finalize() {
    for (int p = 0; p < 4; ++p) {
        uint n = min(blist.ranges[p].count, blist.capacity[p]);
        if (STATIC) blist.static_count[p] = n;
        set_range(blist.ranges[p], n);
        set_range(blist.dynamic_ranges[p], n - blist.static_count[p]);
    }
}

void allocate(ivec3 b) {
    if (brick_map_load(POOL, b) != BRICK_PENDING) return;
    uint s = atomicAdd(blist.ranges[POOL].count, 1u);
    if (s < blist.capacity[POOL]) {
        blist.entries[blist.first[POOL] + s] = pack_brick(b);
        brick_map_store(POOL, b, s + 1u);
    } else {
        atomicAdd(blist.dropped[POOL], 1u);
        brick_map_store(POOL, b, 0u);
    }
}

void release(ivec3 b) {
    uint e = brick_map_load(POOL, b);
    if (e != 0u && e != BRICK_PENDING && e - 1u >= blist.static_count[POOL]) brick_map_store(POOL, b, 0u);
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
    ivec3 b = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(b, ivec3(int(grid.pools[POOL].w))))) return;
    if (MODE == ALLOCATE) {
        allocate(b);
    } else {
        release(b);
    }
}
