// The first update's bounce tail (gi.bounce_tail): what the last bounces added, summed per
// workgroup of the compose dispatch (voxel_bounce_compose.comp), and the gain the tail pass
// (voxel_bounce_tail.comp) derives from them. Mirrors render::passes::voxel_bounce::TailBuffer.
// The including shader defines TAIL_BINDING (and TAIL_QUALIFIER, e.g. readonly).
#ifndef DVSGI_BOUNCE_TAIL_GLSL
#define DVSGI_BOUNCE_TAIL_GLSL

#ifndef TAIL_QUALIFIER
#define TAIL_QUALIFIER
#endif

layout(set = 0, binding = TAIL_BINDING, std430) TAIL_QUALIFIER buffer BounceTailBlock {
    vec4 gain;      // rgb: r / (1 - r) per channel, r the ratio of the two records' sums; a: unused
    vec4 ratio;     // rgb: r (for inspection); a: unused
    vec4 records[]; // [2 * groups]: the first record's workgroup sums, then the second's
} tail;

// Where workgroup `group`'s sum of record `slot` is; `groups`: workgroups per record (the
// list's capacity over VOXEL_LIST_GROUP, a push constant).
uint tail_record_index(uint slot, uint group, uint groups) {
    return slot * groups + group;
}

#endif
