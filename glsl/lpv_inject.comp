#version 460
// Light propagation volume injection, one invocation per reflective-shadow-map texel: a texel
// of flux Phi and normal n is a virtual point light at its position moved half a cell along n
// (against self-lighting), with intensity Phi/pi max(0, n.w), added to its cell; its surface
// adds a blocking lobe area/cell^2 max(0, -n.w) (for light travelling in w) to the geometry of
// the cell it lies in. Sums are fixed point (lpv_accum.glsl); lpv_resolve.comp turns them into
// the volumes.
#include "common.glsl"
#include "sh.glsl"
#include "lpv_accum.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform GridBlock { LpvGrid grid; };
layout(set = 0, binding = 1) uniform sampler2DArray rsm_flux;
layout(set = 0, binding = 2) uniform sampler2DArray rsm_normal;
layout(set = 0, binding = 3) uniform sampler2DArray rsm_position;
layout(set = 0, binding = 4, std430) buffer Accum { int accum[]; };

// The cell holding p, or -1 outside the grid.
int cell_of(vec3 p) {
    int res = int(grid.dims.x);
    ivec3 c = ivec3(floor((p - grid.origin.xyz) / grid.origin.w));
    if (any(lessThan(c, ivec3(0))) || any(greaterThanEqual(c, ivec3(res)))) return -1;
    return c.x + res * (c.y + res * c.z);
}

void add(int cell, uint slot, vec4 v, float quantum) {
    for (uint k = 0u; k < 4u; ++k) {
        int q = int(round(v[k] / quantum));
        if (q != 0) atomicAdd(accum[uint(cell) * LPV_ACCUM_INTS + slot + k], q);
    }
}

void main() {
    ivec3 t = ivec3(gl_GlobalInvocationID.xy, gl_GlobalInvocationID.z);
    ivec3 size = textureSize(rsm_flux, 0);
    if (any(greaterThanEqual(t.xy, size.xy))) return;
    vec4 flux = texelFetch(rsm_flux, t, 0);
    if (flux.a <= 0.0) return;  // no surface in this texel
    vec3 p = texelFetch(rsm_position, t, 0).xyz;
    vec3 n = texelFetch(rsm_normal, t, 0).xyz;
    float s = grid.origin.w;
    int light = cell_of(p + 0.5 * s * n);
    if (light >= 0 && max(flux.r, max(flux.g, flux.b)) > 0.0) {
        vec4 lobe = cos_lobe(n) / PI;
        add(light, 0u, flux.r * lobe, grid.quanta.x);
        add(light, 4u, flux.g * lobe, grid.quanta.x);
        add(light, 8u, flux.b * lobe, grid.quanta.x);
    }
    int surface = cell_of(p);
    if (surface >= 0) add(surface, 12u, cos_lobe(-n) * (flux.a / (s * s)), grid.quanta.y);
}
