#version 460
// Brick allocation (bricks.glsl): every brick of pool POOL's map that the mark pass set to
// pending gets the next free slot of the pool and joins the pool's list of resident bricks.
// Bricks already resident keep their slot: the pools only grow, within capacities that bound
// what voxelization can touch. FINALIZE (one invocation) then writes each pool's indirect
// dispatch over its resident bricks.
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(constant_id = 0) const int POOL = 0;
layout(constant_id = 1) const bool FINALIZE = false;

layout(set = 0, binding = 0) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 1, r32ui) uniform uimage3D brick_maps[4];
#define BRICK_MAPS_WRITABLE
#include "bricks.glsl"
#define BRICK_LIST_BINDING 2
#include "brick_list.glsl"

void main() {
    if (FINALIZE) {
        if (gl_GlobalInvocationID != uvec3(0)) return;
        for (int p = 0; p < 4; ++p) {
            uint n = min(blist.ranges[p].count, blist.capacity[p]);
            blist.ranges[p].count = n;
            blist.ranges[p].groups_x = min(n, BRICK_GROUPS_X);
            blist.ranges[p].groups_y = 8u * ((n + BRICK_GROUPS_X - 1u) / BRICK_GROUPS_X);
            blist.ranges[p].groups_z = 1u;
        }
        return;
    }
    ivec3 b = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(b, ivec3(int(grid.pools[POOL].w))))) return;
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
