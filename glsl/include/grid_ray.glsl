// Rays in voxel-grid units: camera rays for the voxel debug views, and a voxel-by-voxel walk
// (3D DDA) shared by the views and the diagnostic ray gather.
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

// A walk through the voxels a ray crosses, in order (Amanatides & Woo 1987): the current
// voxel c, the step along each axis, the ray parameter of the next boundary on each axis and
// the parameter between two boundaries.
struct VoxelWalk {
    ivec3 c;
    ivec3 stp;
    vec3 next;
    vec3 delta;
};

// The walk of the ray p + t d (voxel units, d unit), starting in the voxel that holds p.
VoxelWalk voxel_walk(vec3 p, vec3 d) {
    VoxelWalk w;
    w.c = ivec3(floor(p));
    w.stp = ivec3(sign(d));
    vec3 inv = 1.0 / d;  // +-inf for zero components: that axis is never stepped
    w.next = (vec3(w.c) + max(vec3(w.stp), vec3(0.0)) - p) * inv;
    w.delta = abs(inv);
    return w;
}

// Step to the next voxel; false once the walk has left the grid of res^3 voxels.
bool voxel_walk_step(inout VoxelWalk w, int res) {
    if (w.next.x < w.next.y && w.next.x < w.next.z) {
        w.c.x += w.stp.x;
        w.next.x += w.delta.x;
    } else if (w.next.y < w.next.z) {
        w.c.y += w.stp.y;
        w.next.y += w.delta.y;
    } else {
        w.c.z += w.stp.z;
        w.next.z += w.delta.z;
    }
    return all(greaterThanEqual(w.c, ivec3(0))) && all(lessThan(w.c, ivec3(res)));
}

#endif
