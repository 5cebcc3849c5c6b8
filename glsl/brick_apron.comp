#version 460
// The aprons of a pooled directional level (bricks.glsl): each resident brick's texels on its
// low faces (local 0 on some axis: texel 8b - 1) copied from the interior of the brick that
// holds them, or zero where that brick is not resident or outside the level. One workgroup of
// 64 per block of the brick dispatch (8 per brick); reads interiors, writes aprons only.
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 64) in;

layout(constant_id = 0) const int POOL = 1;

layout(set = 0, binding = 0, rgba16f) uniform image3D pool[6];
layout(set = 0, binding = 1) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 2, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"
#define BRICK_LIST_BINDING 3
#define BRICK_LIST_QUALIFIER readonly
#include "brick_list.glsl"

#define COPY(FACE) imageStore(pool[FACE], dst, from.x < 0 ? vec4(0.0) : imageLoad(pool[FACE], from))

void main() {
    uint i = brick_dispatch_index(POOL);
    if (i == ~0u) return;
    ivec3 b = unpack_brick(blist.entries[blist.first[POOL] + i]);
    uint e = brick_entry(POOL, b);
    if (e == 0u) return;
    ivec3 origin = entry_texel(e, 9);
    // 8 workgroups of 64 share the brick's 9^3 texels.
    for (uint k = (gl_WorkGroupID.y % 8u) * 64u + gl_LocalInvocationID.x; k < 729u; k += 512u) {
        ivec3 local = ivec3(k % 9u, (k / 9u) % 9u, k / 81u);
        if (all(greaterThan(local, ivec3(0)))) continue;  // interior
        ivec3 from = level_texel(POOL, b * 8 + local - 1);
        ivec3 dst = origin + local;
        COPY(0);
        COPY(1);
        COPY(2);
        COPY(3);
        COPY(4);
        COPY(5);
    }
}
