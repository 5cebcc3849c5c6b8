#version 460
// An exclusive prefix sum, in place, of `count` words of the scan buffer from word `first` on,
// and their total into word `total_at`: one workgroup, each invocation a run of words (integer
// additions in a fixed order: the same offsets whatever order the counts were written in).
// Used to place each brick's voxels in the work list in grid order (voxel_resolve.comp) and
// to give marked bricks their pool slots in grid order (brick_alloc.comp).
// 128 invocations: the most every Vulkan device must support in one workgroup.
layout(local_size_x = 128) in;

layout(set = 0, binding = 0, std430) buffer ScanBlock { uint words[]; };

layout(push_constant) uniform Push {
    uint first;
    uint count;
    uint total_at;
} pc;

shared uint partial[128];

void main() {
    uint i = gl_LocalInvocationIndex;
    uint run = (pc.count + 127u) / 128u;
    uint begin = min(pc.first + i * run, pc.first + pc.count);
    uint end = min(begin + run, pc.first + pc.count);
    uint sum = 0u;
    for (uint j = begin; j < end; ++j) sum += words[j];
    partial[i] = sum;
    barrier();
    for (uint d = 1u; d < 128u; d <<= 1) {
        uint add = i >= d ? partial[i - d] : 0u;
        barrier();
        partial[i] += add;
        barrier();
    }
    uint offset = partial[i] - sum;
    for (uint j = begin; j < end; ++j) {
        uint c = words[j];
        words[j] = offset;
        offset += c;
    }
    if (i == 127u) words[pc.total_at] = partial[127];
}
