// Camera rays in voxel-grid units, for the voxel debug views.
#ifndef DVSGI_GRID_RAY_GLSL
#define DVSGI_GRID_RAY_GLSL
#include "common.glsl"
#include "voxel.glsl"

// The camera ray through pixel px in grid (voxel) units, clipped to the grid box [0, res]^3:
// origin o, unit direction d, entry and exit distances (no hit when tenter >= texit).
struct GridRay {
    vec3 o;
    vec3 d;
    float tenter;
    float texit;
};

GridRay camera_grid_ray(FrameData f, VoxelGrid g, ivec2 px) {
    GridRay r;
    vec2 ndc = (vec2(px) + 0.5) / vec2(f.counts.xy) * 2.0 - 1.0;
    vec4 far_h = f.inv_view_proj * vec4(ndc, 1.0, 1.0);
    r.o = (f.camera_pos.xyz - g.origin.xyz) / g.origin.w;
    r.d = safe_normalize((far_h.xyz / far_h.w - f.camera_pos.xyz) / g.origin.w, vec3(0.0, 0.0, 1.0));
    float res = float(g.dims.x);
    vec3 inv = 1.0 / r.d;  // +-inf for zero components is handled by min/max below
    vec3 t0 = -r.o * inv, t1 = (vec3(res) - r.o) * inv;
    vec3 tn = min(t0, t1), tf = max(t0, t1);
    r.tenter = max(max(tn.x, tn.y), max(tn.z, 0.0));
    r.texit = min(tf.x, min(tf.y, tf.z));
    return r;
}

#endif
