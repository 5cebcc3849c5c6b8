// Workgroup-wide exclusive prefix sum of one value per invocation, and the total, for
// workgroups of 64 invocations (voxel_resolve.comp, brick_alloc.comp): integer additions in a
// fixed order, so every run places the same items at the same offsets.
#ifndef DVSGI_WORKGROUP_SCAN_GLSL
#define DVSGI_WORKGROUP_SCAN_GLSL

shared uint scan_partial[64];

uint workgroup_exclusive_scan(uint v, out uint total) {
    uint i = gl_LocalInvocationIndex;
    scan_partial[i] = v;
    barrier();
    for (uint d = 1u; d < 64u; d <<= 1) {
        uint add = i >= d ? scan_partial[i - d] : 0u;
        barrier();
        scan_partial[i] += add;
        barrier();
    }
    total = scan_partial[63];
    uint inclusive = scan_partial[i];
    barrier();
    return inclusive - v;
}

#endif
