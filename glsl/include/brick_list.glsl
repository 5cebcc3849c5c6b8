// Resident bricks of each pool (mirrors render::bricks::list_header): for each pool, an
// indirect dispatch over its resident bricks (8 workgroups of 4^3 per brick along y, spilling
// into more y past 32768 bricks along x) and its count; where each pool's entries start, how
// many it may hold, how many bricks did not fit (never: the capacity is an upper bound), how
// many are static (the first ones: their slots never change), and a dispatch over the rest,
// the dynamic bricks (allocated anew at each dynamic update). A brick's slot is its position
// in its pool's list.
// The including shader defines BRICK_LIST_BINDING (and BRICK_LIST_QUALIFIER).
#ifndef DVSGI_BRICK_LIST_GLSL
#define DVSGI_BRICK_LIST_GLSL

#ifndef BRICK_LIST_QUALIFIER
#define BRICK_LIST_QUALIFIER
#endif

#define BRICK_GROUPS_X 32768u

struct BrickRange {
    uint groups_x, groups_y, groups_z;
    uint count;
};

layout(set = 0, binding = BRICK_LIST_BINDING, std430) BRICK_LIST_QUALIFIER buffer BrickListBlock {
    BrickRange ranges[4];
    uint first[4];
    uint capacity[4];
    uint dropped[4];
    uint static_count[4];
    BrickRange dynamic_ranges[4];
    uint entries[];  // brick coordinates, 10 bits each
} blist;

uint pack_brick(ivec3 b) {
    return uint(b.x) | (uint(b.y) << 10) | (uint(b.z) << 20);
}

ivec3 unpack_brick(uint w) {
    return ivec3(w & 0x3ffu, (w >> 10) & 0x3ffu, w >> 20);
}

// The resident brick this workgroup of an indirect brick dispatch of pool p covers (its index
// in the list, or ~0u past the end) and which of its 8 blocks of 4^3 (0..7).
uint brick_dispatch_index(int p) {
    uint i = gl_WorkGroupID.x + BRICK_GROUPS_X * (gl_WorkGroupID.y / 8u);
    return i < blist.ranges[p].count ? i : ~0u;
}

// The slot of the dynamic brick this workgroup of an indirect dispatch over pool p's
// dynamic range covers (~0u past the end).
uint brick_dynamic_slot(int p) {
    uint i = gl_WorkGroupID.x + BRICK_GROUPS_X * (gl_WorkGroupID.y / 8u);
    return i < blist.dynamic_ranges[p].count ? blist.static_count[p] + i : ~0u;
}

#endif
