#version 460
// The first update's bounce tail (gi.bounce_tail): after n bounces the light each bounce adds
// shrinks by about the same ratio r every bounce (the largest eigenvalue of the bounce, once
// the others have died out), so the bounces not run add d r / (1 - r), d the last one's
// increment (Aitken's extrapolation of a geometric series; the "ambient term" of progressive
// radiosity). r per channel: the sum over every voxel of what bounce n - 1 added over what
// bounce n - 2 added (voxel_bounce_compose.comp's two records). One workgroup sums each
// record's workgroup sums in a fixed order, so the gain is the same bytes on every run.
#include "common.glsl"

layout(local_size_x = 256) in;

#define VOXEL_LIST_BINDING 0
#define VOXEL_LIST_QUALIFIER readonly
#include "voxel_list.glsl"
#define TAIL_BINDING 1
#include "bounce_tail.glsl"
layout(push_constant) uniform Push { uint groups; } pc;  // workgroups per record

// The largest ratio taken (r / (1 - r) = 19 bounces' worth of the last increment): a ratio
// near or past 1 is a scene whose light hardly converges (white all round, closed) or
// records too small to be a series, where a few more bounces are as far as the tail goes.
const float MAX_RATIO = 0.95;

shared vec3 first_sum[256];
shared vec3 second_sum[256];

void main() {
    uint i = gl_LocalInvocationIndex;
    uint groups = min(vlist.occupied.groups_x * vlist.occupied.groups_y, pc.groups);
    vec3 a = vec3(0.0), b = vec3(0.0);
    for (uint g = i; g < groups; g += 256u) {
        a += tail.records[tail_record_index(0u, g, pc.groups)].rgb;
        b += tail.records[tail_record_index(1u, g, pc.groups)].rgb;
    }
    first_sum[i] = a;
    second_sum[i] = b;
    barrier();
    for (uint half_ = 128u; half_ > 0u; half_ >>= 1u) {
        if (i < half_) {
            first_sum[i] += first_sum[i + half_];
            second_sum[i] += second_sum[i + half_];
        }
        barrier();
    }
    if (i == 0u) {
        vec3 s0 = first_sum[0], s1 = second_sum[0];
        vec3 r = vec3(0.0);
        for (int c = 0; c < 3; ++c) {
            if (s0[c] > 0.0 && s1[c] > 0.0) r[c] = min(s1[c] / s0[c], MAX_RATIO);
        }
        tail.ratio = vec4(r, 0.0);
        tail.gain = vec4(r / (1.0 - r), 0.0);
    }
}
