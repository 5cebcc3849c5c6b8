#version 460
// Light propagation volume injection, as a gather (deterministic, no atomics): each cell
// collects the reflective-shadow-map texels whose virtual point light falls in it. A texel of
// flux Phi and normal n is a VPL at its position moved half a cell along n (against self-
// lighting), with intensity Phi/pi max(0, n.w). The geometry volume gets each texel whose
// surface lies in the cell as a blocking lobe: area/cell^2 max(0, -n.w) for light travelling in
// w. The texels a cell can hold lie in the map's rectangle around the cell's projection
// (grown by the half-cell offset); rectangles wider than MAX_SPAN texels are walked with a
// stride, each visited texel standing for stride^2 of them.
#include "common.glsl"
#include "sh.glsl"
#define SHADOW_VIEWS_BINDING 1
#include "shadow.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(constant_id = 0) const uint VIEW_COUNT = 1;
layout(constant_id = 1) const int MAX_SPAN = 64;

layout(set = 0, binding = 0) uniform GridBlock { LpvGrid grid; };
layout(set = 0, binding = 2, std430) readonly buffer RsmViews { uvec4 rsm_views[]; };  // x shadow view
layout(set = 0, binding = 3) uniform sampler2DArray rsm_flux;
layout(set = 0, binding = 4) uniform sampler2DArray rsm_normal;
layout(set = 0, binding = 5) uniform sampler2DArray rsm_position;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image3D light_r;
layout(set = 0, binding = 7, rgba32f) uniform writeonly image3D light_g;
layout(set = 0, binding = 8, rgba32f) uniform writeonly image3D light_b;
layout(set = 0, binding = 9, rgba32f) uniform writeonly image3D geometry;
layout(set = 0, binding = 10, rgba32f) uniform writeonly image3D sum_r;
layout(set = 0, binding = 11, rgba32f) uniform writeonly image3D sum_g;
layout(set = 0, binding = 12, rgba32f) uniform writeonly image3D sum_b;

// The texel rectangle [lo, hi] of the map that can hold the cell's texels: the bounding box
// of the grown cell's corners in the view, the whole map when a corner is behind the light.
ivec4 footprint(mat4 view_proj, vec3 lo, vec3 hi, ivec2 size) {
    vec2 a = vec2(1e30), b = vec2(-1e30);
    for (int i = 0; i < 8; ++i) {
        vec3 p = vec3((i & 1) != 0 ? hi.x : lo.x, (i & 2) != 0 ? hi.y : lo.y, (i & 4) != 0 ? hi.z : lo.z);
        vec4 c = view_proj * vec4(p, 1.0);
        if (c.w <= 1e-6) return ivec4(0, 0, size - 1);
        vec2 t = (c.xy / c.w * 0.5 + 0.5) * vec2(size);
        a = min(a, t);
        b = max(b, t);
    }
    a = clamp(floor(a), vec2(0.0), vec2(size - 1));
    b = clamp(floor(b), vec2(0.0), vec2(size - 1));
    return ivec4(a, b);
}

void main() {
    int res = int(grid.dims.x);
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(c, ivec3(res)))) return;
    float s = grid.origin.w;
    vec3 lo = grid.origin.xyz + vec3(c) * s;
    vec3 hi = lo + vec3(s);
    vec4 r = vec4(0.0), g = vec4(0.0), b = vec4(0.0), occ = vec4(0.0);
    ivec2 size = textureSize(rsm_flux, 0).xy;
    for (uint v = 0u; v < VIEW_COUNT; ++v) {
        ivec4 rect = footprint(views[rsm_views[v].x].view_proj, lo - 0.5 * s, hi + 0.5 * s, size);
        int span = max(rect.z - rect.x, rect.w - rect.y) + 1;
        int stride = (span + MAX_SPAN - 1) / MAX_SPAN;
        float weight = float(stride * stride);
        for (int y = rect.y; y <= rect.w; y += stride) {
            for (int x = rect.x; x <= rect.z; x += stride) {
                ivec3 t = ivec3(x, y, int(v));
                vec4 flux = texelFetch(rsm_flux, t, 0);
                if (flux.a <= 0.0) continue;
                vec3 p = texelFetch(rsm_position, t, 0).xyz;
                vec3 n = texelFetch(rsm_normal, t, 0).xyz;
                vec3 q = p + 0.5 * s * n;
                if (all(greaterThanEqual(q, lo)) && all(lessThan(q, hi))) {
                    vec4 lobe = cos_lobe(n) * (weight / PI);
                    r += flux.r * lobe;
                    g += flux.g * lobe;
                    b += flux.b * lobe;
                }
                if (all(greaterThanEqual(p, lo)) && all(lessThan(p, hi))) {
                    occ += cos_lobe(-n) * (flux.a * weight / (s * s));
                }
            }
        }
    }
    imageStore(light_r, c, r);
    imageStore(light_g, c, g);
    imageStore(light_b, c, b);
    imageStore(geometry, c, occ);
    bool summed = grid.dims.z == 0u;
    imageStore(sum_r, c, summed ? r : vec4(0.0));
    imageStore(sum_g, c, summed ? g : vec4(0.0));
    imageStore(sum_b, c, summed ? b : vec4(0.0));
}
