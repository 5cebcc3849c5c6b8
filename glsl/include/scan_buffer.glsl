// The scan buffer (mirrors render::voxel::scan_layout): a header of totals, then per 8^3 brick
// of the grid its occupied voxels (voxel_resolve.comp), then per pool of bricks one word per
// block of 512 map entries (brick_alloc.comp); scan.comp turns each run of counts into
// offsets and writes their total into the header. Words are indexed from the buffer's start.
// The including shader defines SCAN_BINDING.
#ifndef DVSGI_SCAN_BUFFER_GLSL
#define DVSGI_SCAN_BUFFER_GLSL

const uint SCAN_VOXEL_TOTAL = 0u;   // occupied voxels of the static voxelization
const uint SCAN_POOL_TOTAL = 4u;    // + pool: bricks the allocation marked pending
const uint SCAN_VOXELS = 16u;       // first word of the per-brick voxel counts
// Map entries a workgroup of the brick allocation covers (64 invocations, 8 each).
const uint SCAN_BLOCK = 512u;

layout(set = 0, binding = SCAN_BINDING, std430) buffer ScanBlock { uint words[]; } scan;

#endif
