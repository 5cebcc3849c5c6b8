// Work lists of occupied voxels (mirrors render::voxel::VoxelList). The list holds every
// occupied voxel exactly once: the static voxels first (entries [0, static_count)), in grid
// order (voxel_resolve.comp builds them after the static voxelization: 8^3 bricks in grid
// order, voxels in grid order within a brick, so list positions repeat from run to run), then
// the dynamic ones of the last revoxelization ([static_count, occupied)), appended by the
// voxelizer as each one's first sample arrives (their order decides nothing numeric). The voxel passes dispatch
// indirectly over it (each range's group counts are kept beside it by voxel_list.comp), so
// they cost what the scene's surfaces hold, not the grid's N^3.
// The including shader defines VOXEL_LIST_BINDING (and VOXEL_LIST_QUALIFIER, e.g. readonly;
// VOXEL_LIST_APPEND_ONLY outside compute shaders)
// and, where it reads them, VOXEL_STALE_BINDING: the voxels the last dynamic clear emptied,
// whose radiance the next relight zeroes unless they are occupied again.
#ifndef DVSGI_VOXEL_LIST_GLSL
#define DVSGI_VOXEL_LIST_GLSL

#ifndef VOXEL_LIST_QUALIFIER
#define VOXEL_LIST_QUALIFIER
#endif

// Invocations per workgroup of every list-driven dispatch (1D).
#define VOXEL_LIST_GROUP 64u
// Workgroups along x of a list dispatch; more spill into y (maxComputeWorkGroupCount[0] is
// only guaranteed to be 65535).
#define VOXEL_LIST_GROUPS_X 32768u

// One range of the list and the indirect dispatch (VkDispatchIndirectCommand) that covers it.
struct ListRange {
    uint groups_x, groups_y, groups_z;
    uint count;
};

layout(set = 0, binding = VOXEL_LIST_BINDING, std430) VOXEL_LIST_QUALIFIER buffer VoxelListBlock {
    ListRange occupied;   // every occupied voxel: [0, occupied.count)
    ListRange dynamic;    // the dynamic voxels: [static_count, occupied.count), count = that length
    ListRange stale;      // the stale list: [0, stale.count)
    uint static_count;
    uint dropped;         // appends past the capacity (never, with a capacity of N^3)
    uint pad0, pad1;
    uint entries[];
} vlist;

#ifdef VOXEL_STALE_BINDING
layout(set = 0, binding = VOXEL_STALE_BINDING, std430) VOXEL_LIST_QUALIFIER buffer VoxelStaleBlock {
    uint stale_entries[];
};
#endif

// Grid coordinates (each < 1024) in one word.
uint pack_voxel(ivec3 c) {
    return uint(c.x) | (uint(c.y) << 10) | (uint(c.z) << 20);
}

ivec3 unpack_voxel(uint v) {
    return ivec3(v & 0x3ffu, (v >> 10) & 0x3ffu, (v >> 20) & 0x3ffu);
}

#ifndef VOXEL_LIST_APPEND_ONLY  // compute shaders: dispatches over the list
// The list position of this invocation in a list dispatch of VOXEL_LIST_GROUP invocations
// per group.
uint list_invocation() {
    return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * VOXEL_LIST_GROUP + gl_LocalInvocationIndex;
}
#endif

// The dispatch covering `count` list entries.
ListRange list_range(uint count) {
    uint groups = (count + VOXEL_LIST_GROUP - 1u) / VOXEL_LIST_GROUP;
    ListRange r;
    r.groups_x = min(groups, VOXEL_LIST_GROUPS_X);
    r.groups_y = (groups + VOXEL_LIST_GROUPS_X - 1u) / VOXEL_LIST_GROUPS_X;
    r.groups_z = 1u;
    r.count = count;
    return r;
}

#endif
