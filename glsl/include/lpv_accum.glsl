// The light propagation volume's injection accumulator: per cell 16 ints, fixed point (mirrors
// render::passes::lpv): 12 light coefficients (red, green, blue; 4 SH each) in units of
// `grid.quanta.x`, then 4 geometry coefficients in units of `grid.quanta.y`. Integer atomics
// add in any order to the same sum, so the injection is deterministic.
#ifndef DVSGI_LPV_ACCUM_GLSL
#define DVSGI_LPV_ACCUM_GLSL
const uint LPV_ACCUM_INTS = 16u;
#endif
