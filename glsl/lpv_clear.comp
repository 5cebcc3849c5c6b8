#version 460
// Zeroes the injection accumulator (one cell per invocation) before the texels are added.
#include "sh.glsl"
#include "lpv_accum.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(set = 0, binding = 0) uniform GridBlock { LpvGrid grid; };
layout(set = 0, binding = 1, std430) writeonly buffer Accum { int accum[]; };

void main() {
    int res = int(grid.dims.x);
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(c, ivec3(res)))) return;
    uint base = uint(c.x + res * (c.y + res * c.z)) * LPV_ACCUM_INTS;
    for (uint i = 0u; i < LPV_ACCUM_INTS; ++i) accum[base + i] = 0;
}
