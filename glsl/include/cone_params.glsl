// Cone-tracing parameters (mirrors render::cones::GpuGiParams).
#ifndef DVSGI_CONE_PARAMS_GLSL
#define DVSGI_CONE_PARAMS_GLSL

struct GiParams {
    vec4 cones[16];     // xyz tangent-space direction, w weight
    vec4 cone_tan[16];  // x tan(half aperture)
    uvec4 counts;       // x diffuse cones, y downsample, z directional mip levels, w flags (1 AO,
                        // 2 two-tap filtering: the directional volumes hold opacity, 4 layers opacity,
                        // 8 quadrant footprints, 16 quarters' shares)
    vec4 trace;         // x step factor beta, y max distance (voxels), z start offset (voxels), w AO falloff per voxel
    vec4 shadow;        // x tan(half aperture) of shadow cones
};

const uint GI_FLAG_AO = 1u;
const uint GI_FLAG_TWO_TAP = 2u;
const uint GI_FLAG_LAYERS = 4u;  // gi.opacity = "layers" (cone.glsl)
const uint GI_FLAG_QUADRANTS = 8u;  // gi.footprint = "quadrants" (cone.glsl)
const uint GI_FLAG_SHARES = 16u;  // gi.footprint = "shares" (cone.glsl)

#endif
