#version 460
// After a voxelization: the sums of every voxel that received samples (voxel.glsl) become the
// averages the voxel passes read (albedo, emission: RGB8 and the sample count, capped at 255;
// normal: RGB8 and where the surface lies in the voxel), and the sums are zeroed for the next
// voxelization. One mode per dispatch:
//   COUNT  (one workgroup per 8^3 brick of the grid, dense or bricked): how many of its voxels
//          received samples, into the scan buffer (one word per brick, in grid order).
//   WRITE  (the same workgroups, after scan.comp turned the counts into offsets): each
//          occupied voxel takes its place in the work list, bricks in grid order and voxels
//          in grid order within a brick, and is resolved. So the static list, whose positions
//          decide which voxels gather light in each update of an interleaved bounce
//          (voxel_bounce.comp), is the same on every run, whatever order fragments came in.
//   RESOLVE (one invocation per entry of the list's dynamic range, indirect): the dynamic
//          voxels, which the dynamic voxelization appended (their order decides nothing).
#include "common.glsl"
#include "voxel.glsl"
#include "workgroup_scan.glsl"

layout(local_size_x = 64) in;

#define COUNT 0
#define WRITE 1
#define RESOLVE 2
layout(constant_id = 0) const int MODE = COUNT;
layout(constant_id = 1) const bool HAS_EMISSION = false;
// gi.attenuation = "per-side": the normals seen from each side (voxel.glsl, SUM_SIDES).
layout(constant_id = 2) const bool SIDE_NORMALS = false;

layout(set = 0, binding = 0) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 1, r32ui) uniform uimage3D vox_sums[SUM_WORDS];
layout(set = 0, binding = 2, r32ui) uniform writeonly uimage3D vox_albedo;
layout(set = 0, binding = 3, r32ui) uniform writeonly uimage3D vox_normal;
layout(set = 0, binding = 4, r32ui) uniform writeonly uimage3D vox_emission;
#define VOXEL_LIST_BINDING 5
#include "voxel_list.glsl"
#define SCAN_BINDING 6
#include "scan_buffer.glsl"
layout(set = 0, binding = 7, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"
layout(set = 0, binding = 8, rgba32ui) uniform writeonly uimage3D vox_side_normals;

// The average of three channels of the sums from word `first` on, and those sums zeroed.
vec3 take_mean(ivec3 t, int first, uint count) {
    uvec3 sum = uvec3(imageLoad(vox_sums[first], t).r, imageLoad(vox_sums[first + 1], t).r,
                      imageLoad(vox_sums[first + 2], t).r);
    for (int i = 0; i < 3; ++i) imageStore(vox_sums[first + i], t, uvec4(0u));
    return sum_mean(sum, count, grid.dims.w);
}

// The six sides' normals of voxel texel t (voxel.glsl, pack_side_normal) from its `count`
// samples' sums; those sums back to zero.
uvec4 take_side_normals(ivec3 t, uint count) {
    uvec4 packed = uvec4(0u);
    for (int j = 0; j < 6; ++j) {
        int first = SUM_SIDES + 4 * j;
        vec4 sum;
        for (int i = 0; i < 4; ++i) {
            sum[i] = float(int(imageLoad(vox_sums[first + i], t).r));
            imageStore(vox_sums[first + i], t, uvec4(0u));
        }
        // sum.w: the weights' sum, in halves of the fixed-point one.
        if (sum.w <= SIDE_SEEN * 0.5 * float(count) * float(grid.dims.w)) continue;
        pack_side_normal(packed, sum.xyz / sum.w, j);
    }
    return packed;
}

// Voxel texel t's averages from its `count` samples; its sums back to zero.
void resolve(ivec3 t, uint count) {
    float n = float(min(count, 255u));
    imageStore(vox_sums[SUM_COUNT], t, uvec4(0u));
    // With gi.voxel_cover = "area" the fourth byte holds how much of the voxel its surfaces
    // cover (voxel.glsl), else the sample count; either is 0 only where the voxel is empty.
    float fourth = n;
    if (AREA_COVER) {
        fourth = cover_code(float(imageLoad(vox_sums[SUM_COVER], t).r) / float(grid.dims.w));
        imageStore(vox_sums[SUM_COVER], t, uvec4(0u));
    }
    imageStore(vox_albedo, t, uvec4(pack_rgb_count(take_mean(t, SUM_ALBEDO, count) * 255.0, fourth)));
    // The normal volume's fourth byte holds where the surface lies (voxel.glsl, SUM_OFFSET).
    float offset = float(max(imageLoad(vox_sums[SUM_OFFSET], t).r, 1u) - 1u);
    imageStore(vox_sums[SUM_OFFSET], t, uvec4(0u));
    imageStore(vox_normal, t, uvec4(pack_rgb_count(take_mean(t, SUM_NORMAL, count) * 255.0, offset)));
    if (HAS_EMISSION) {
        imageStore(vox_emission, t, uvec4(pack_rgb_count(take_mean(t, SUM_EMISSION, count) * 255.0, n)));
    }
    if (SIDE_NORMALS) imageStore(vox_side_normals, t, take_side_normals(t, count));
}

void brick_pass() {
    ivec3 b = ivec3(gl_WorkGroupID);
    int side = (int(grid.dims.x) + 7) / 8;
    uint index = uint(b.x + side * (b.y + side * b.z));
    // Dense: the brick's voxels are texels of the volume; bricked: of its slot, if resident.
    ivec3 origin = b * 8;
    if (bricked()) {
        uint e = brick_entry(0, b);
        origin = e == 0u ? ivec3(-1) : entry_texel(e, 8);
    }
    // Each invocation a row of 8 voxels along x.
    ivec3 row = ivec3(0, int(gl_LocalInvocationIndex & 7u), int(gl_LocalInvocationIndex >> 3));
    uint counts[8];
    uint occupied = 0u;
    for (int x = 0; x < 8; ++x) {
        ivec3 c = b * 8 + row + ivec3(x, 0, 0);
        bool inside = origin.x >= 0 && all(lessThan(c, ivec3(int(grid.dims.x))));
        counts[x] = inside ? imageLoad(vox_sums[SUM_COUNT], origin + row + ivec3(x, 0, 0)).r : 0u;
        occupied += counts[x] != 0u ? 1u : 0u;
    }
    uint total;
    uint before = workgroup_exclusive_scan(occupied, total);
    if (MODE == COUNT) {
        if (gl_LocalInvocationIndex == 0u) scan.words[SCAN_VOXELS + index] = total;
        return;
    }
    // The list's length (voxel_list.comp clamps it to the capacity; never needed).
    if (index == 0u && gl_LocalInvocationIndex == 0u) vlist.occupied.count = scan.words[SCAN_VOXEL_TOTAL];
    uint next = scan.words[SCAN_VOXELS + index] + before;
    for (int x = 0; x < 8; ++x) {
        if (counts[x] == 0u) continue;
        ivec3 c = b * 8 + row + ivec3(x, 0, 0);
        if (next < uint(vlist.entries.length())) {
            vlist.entries[next] = pack_voxel(c);
        } else {
            atomicAdd(vlist.dropped, 1u);
        }
        ++next;
        resolve(origin + row + ivec3(x, 0, 0), counts[x]);
    }
}

void main() {
    if (MODE != RESOLVE) {
        brick_pass();
        return;
    }
    uint i = list_invocation();
    if (i >= vlist.dynamic.count) return;
    ivec3 t = full_texel(unpack_voxel(vlist.entries[vlist.static_count + i]));
    if (t.x < 0) return;
    uint count = imageLoad(vox_sums[SUM_COUNT], t).r;
    if (count != 0u) resolve(t, count);
}
