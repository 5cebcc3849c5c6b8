// 2-band spherical harmonics and the light propagation volume's grid (mirror render::lpv).
// Basis order: Y00, Y1-1 ~ y, Y10 ~ z, Y11 ~ x. A cell holds, per colour, the coefficients of
// an intensity distribution (W/sr) of light travelling in each direction.
#ifndef DVSGI_SH_GLSL
#define DVSGI_SH_GLSL

struct LpvGrid {
    vec4 origin;  // xyz min corner, w cell size
    uvec4 dims;   // x cells per side, y 1 with occlusion, z leading terms left out of the sum
                  // (0: all; `rsm+lpv` 2: the injected light and the first step's, which the
                  // RSM gather covers)
    vec4 quanta;  // x light, y geometry: the value of one unit of the injection's fixed point
};

const float SH_C0 = 0.2820948;
const float SH_C1 = 0.4886025;
const float COS_LOBE_C0 = 0.8862269;  // sqrt(pi) / 2
const float COS_LOBE_C1 = 1.0233267;  // sqrt(pi / 3)

vec4 sh_eval(vec3 w) {
    return vec4(SH_C0, SH_C1 * w.y, SH_C1 * w.z, SH_C1 * w.x);
}

// The clamped cosine lobe max(0, n.w) around unit n.
vec4 cos_lobe(vec3 n) {
    return vec4(COS_LOBE_C0, COS_LOBE_C1 * n.y, COS_LOBE_C1 * n.z, COS_LOBE_C1 * n.x);
}

#endif
