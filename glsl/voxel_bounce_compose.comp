#version 460
// The bounced radiance of every occupied voxel (work list): its direct radiance (this
// update's, voxel_light.comp) plus the indirect light of its last bounce gather
// (voxel_bounce.comp). Stale voxels are zeroed beforehand (voxel_stale.comp).
// In the first update (gi.bounce_tail, voxel_bounce_tail.comp) the last bounces also measure
// how much light each added, and the last adds the geometric tail of the bounces not run:
// * TAIL_RECORD_FIRST / TAIL_RECORD_SECOND: each workgroup writes the sum, over its voxels,
//   of what this bounce added to their radiance (new less old; per channel) to its slot of
//   the first or second record, for the tail's ratio.
// * TAIL_EXTRAPOLATE: each voxel's increment d of this bounce is continued as a geometric
//   series with the ratio r the tail pass measured: d (r + r^2 + ...) = d r / (1 - r) more,
//   added to the bounced radiance and to the scratch volume's indirect light (which voxels
//   that do not gather in a later update keep).
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 64) in;

#define TAIL_NONE 0u
#define TAIL_RECORD_FIRST 1u
#define TAIL_RECORD_SECOND 2u
#define TAIL_EXTRAPOLATE 3u
layout(push_constant) uniform Push {
    uint tail;    // TAIL_*
    uint groups;  // workgroups per record (bounce_tail.glsl)
} pc;

#define VOXEL_LIST_BINDING 0
#define VOXEL_LIST_QUALIFIER readonly
#include "voxel_list.glsl"
layout(set = 0, binding = 1, rgba16f) uniform readonly image3D vox_direct;
layout(set = 0, binding = 2, rgba16f) uniform image3D vox_indirect;
layout(set = 0, binding = 3, rgba16f) uniform image3D vox_bounced;
layout(set = 0, binding = 4) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 5, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"
#define TAIL_BINDING 6
#include "bounce_tail.glsl"

shared vec3 group_sum[64];

// The workgroup's sum of `v` over its invocations, in a fixed order (the same bytes whatever
// the order workgroups run in), written to record `slot`.
void record(vec3 v, uint slot) {
    group_sum[gl_LocalInvocationIndex] = v;
    barrier();
    for (uint half_ = 32u; half_ > 0u; half_ >>= 1u) {
        if (gl_LocalInvocationIndex < half_) {
            group_sum[gl_LocalInvocationIndex] += group_sum[gl_LocalInvocationIndex + half_];
        }
        barrier();
    }
    if (gl_LocalInvocationIndex == 0u) {
        uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
        if (group < pc.groups) tail.records[tail_record_index(slot, group, pc.groups)] = vec4(group_sum[0], 0.0);
    }
}

void main() {
    uint entry = list_invocation();
    vec3 added = vec3(0.0);
    ivec3 c = ivec3(0);
    ivec3 t = ivec3(-1);
    if (entry < vlist.occupied.count) {
        c = unpack_voxel(vlist.entries[entry]);
        t = full_texel(c);
    }
    if (t.x >= 0) {
        // The direct radiance is sampled by cones (9^3 per slot), the scratch volume is not
        // (8^3). The direct radiance is premultiplied by the voxel's cover (voxel_light.comp),
        // the gathered light is not.
        vec4 direct = imageLoad(vox_direct, radiance_texel(c));
        vec3 indirect = imageLoad(vox_indirect, t).rgb;
        vec3 sum = direct.rgb + indirect * direct.a;
        if (pc.tail != TAIL_NONE) {
            // What this bounce added: the bounced radiance still holds the last bounce's.
            added = sum - imageLoad(vox_bounced, radiance_texel(c)).rgb;
        }
        if (pc.tail == TAIL_EXTRAPOLATE && direct.a > 0.0) {
            vec3 more = added * tail.gain.rgb;
            sum += more;
            imageStore(vox_indirect, t, vec4(min(indirect + more / direct.a, vec3(HALF_MAX)), 1.0));
        }
        RADIANCE_STORE(vox_bounced, c, vec4(min(sum, vec3(HALF_MAX)), direct.a));
    }
    // Uniform per dispatch (a push constant): every invocation of the group reaches the barriers.
    if (pc.tail == TAIL_RECORD_FIRST || pc.tail == TAIL_RECORD_SECOND) record(added, pc.tail - 1u);
}
