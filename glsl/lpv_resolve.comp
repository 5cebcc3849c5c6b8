#version 460
// The injection's fixed-point sums into the volumes: the light (the first propagation step's
// input), the geometry, and the running sum (which starts with the injected light unless
// grid.dims.z leaves it out).
#include "common.glsl"
#include "sh.glsl"
#include "lpv_accum.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(set = 0, binding = 0) uniform GridBlock { LpvGrid grid; };
layout(set = 0, binding = 1, std430) readonly buffer Accum { int accum[]; };
layout(set = 0, binding = 2, rgba32f) uniform writeonly image3D light_r;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image3D light_g;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image3D light_b;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image3D geometry;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image3D sum_r;
layout(set = 0, binding = 7, rgba32f) uniform writeonly image3D sum_g;
layout(set = 0, binding = 8, rgba32f) uniform writeonly image3D sum_b;

vec4 load(uint base, float quantum) {
    return vec4(accum[base], accum[base + 1u], accum[base + 2u], accum[base + 3u]) * quantum;
}

void main() {
    int res = int(grid.dims.x);
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(c, ivec3(res)))) return;
    uint base = uint(c.x + res * (c.y + res * c.z)) * LPV_ACCUM_INTS;
    vec4 r = load(base, grid.quanta.x), g = load(base + 4u, grid.quanta.x), b = load(base + 8u, grid.quanta.x);
    imageStore(light_r, c, r);
    imageStore(light_g, c, g);
    imageStore(light_b, c, b);
    imageStore(geometry, c, load(base + 12u, grid.quanta.y));
    bool summed = grid.dims.z == 0u;
    imageStore(sum_r, c, summed ? r : vec4(0.0));
    imageStore(sum_g, c, summed ? g : vec4(0.0));
    imageStore(sum_b, c, summed ? b : vec4(0.0));
}
