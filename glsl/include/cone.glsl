// Voxel cone tracing, shared by the per-pixel tracer, the bounce pass and the mip view.
// The including shader declares, before including this file (GiParams is in cone_params.glsl):
//   uniform GridBlock { VoxelGrid grid; };        uniform GiBlock { GiParams gi; };
//   uniform sampler3D vox_lod0;                   (full-resolution radiance, RGBA16F)
//   uniform sampler3D aniso[6];                   (+x, -x, +y, -y, +z, -z directional volumes)
// Positions are in voxel units: 0..res along each axis of the grid.
#ifndef DVSGI_CONE_GLSL
#define DVSGI_CONE_GLSL
#include "common.glsl"
#include "voxel.glsl"
#include "cone_params.glsl"

// The directional volumes at `level`, blended by the squared components of `dir` (the
// direction the cone travels): the volume integrated along +x serves cones going +x.
vec4 sample_anisotropic(vec3 uvw, vec3 dir, float level) {
    vec3 w = dir * dir;
    vec4 x = dir.x >= 0.0 ? textureLod(aniso[0], uvw, level) : textureLod(aniso[1], uvw, level);
    vec4 y = dir.y >= 0.0 ? textureLod(aniso[2], uvw, level) : textureLod(aniso[3], uvw, level);
    vec4 z = dir.z >= 0.0 ? textureLod(aniso[4], uvw, level) : textureLod(aniso[5], uvw, level);
    return (x * w.x + y * w.y + z * w.z) / max(w.x + w.y + w.z, 1e-12);
}

// Quadrilinear sample at voxel-space position g and level of detail `lod` (log2 of the
// footprint in voxels): below 1 the full-resolution volume blends into the directional
// volumes' level 0 (which is lod 1); above, the directional mips blend trilinearly.
vec4 sample_voxels(vec3 g, vec3 dir, float lod) {
    vec3 uvw = g / float(grid.dims.x);
    float top = float(gi.counts.z);  // lod of the last directional level + 1
    lod = clamp(lod, 0.0, top);
    if (lod < 1.0) {
        vec4 full = textureLod(vox_lod0, uvw, 0.0);
        if (lod <= 0.0) return full;
        return mix(full, sample_anisotropic(uvw, dir, 0.0), lod);
    }
    return sample_anisotropic(uvw, dir, lod - 1.0);
}

struct ConeResult {
    vec3 radiance;    // radiance arriving along the cone (front-to-back composited)
    float opacity;    // accumulated opacity
    float occlusion;  // opacity weighted by f(r) = 1 / (1 + falloff r), for ambient occlusion
};

// March a cone from g (voxel units) along unit `dir` with half-aperture tangent `tan_half`
// up to `max_t` voxels. Steps are `beta` times the cone diameter; each sample's opacity is
// corrected for the step length (1 - (1 - a)^beta) so results do not depend on beta beyond
// sampling error.
ConeResult trace_cone(vec3 g, vec3 dir, float tan_half, float max_t) {
    ConeResult r;
    r.radiance = vec3(0.0);
    r.opacity = 0.0;
    r.occlusion = 0.0;
    float res = float(grid.dims.x);
    float beta = max(gi.trace.x, 0.01);
    float falloff = gi.trace.w;
    tan_half = clamp(tan_half, 1e-4, 20.0);
    max_t = min(max_t, gi.trace.y);
    float t = 0.0;
    for (int i = 0; i < 2048 && t < max_t && r.opacity < 0.99; ++i) {
        vec3 p = g + dir * t;
        if (any(lessThan(p, vec3(0.0))) || any(greaterThan(p, vec3(res)))) break;
        float diameter = max(1.0, 2.0 * tan_half * t);
        vec4 s = sample_voxels(p, dir, log2(diameter));
        float a = clamp(s.a, 0.0, 1.0);
        if (a > 0.0) {
            float corrected = 1.0 - pow(1.0 - min(a, 0.9999), beta);
            vec3 rgb = max(s.rgb, vec3(0.0)) * (corrected / a);
            r.radiance += (1.0 - r.opacity) * rgb;
            r.occlusion += (1.0 - r.occlusion) * corrected / (1.0 + falloff * t);
            r.opacity += (1.0 - r.opacity) * corrected;
        }
        t += beta * diameter;
    }
    r.radiance = min(r.radiance, vec3(HALF_MAX));
    return r;
}

// An orthonormal basis around unit n (Duff et al. 2017).
mat3 tangent_frame(vec3 n) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    vec3 bt = vec3(b, s + n.y * n.y * a, -n.y);
    return mat3(t, bt, n);
}

// Diffuse cones over the hemisphere of unit N from voxel-space position g: the cosine-weighted
// mean incoming radiance (irradiance / pi) in rgb and the AO factor (1 = unoccluded) in a.
vec4 trace_diffuse(vec3 g, vec3 N) {
    mat3 tbn = tangent_frame(N);
    vec3 sum = vec3(0.0);
    float occlusion = 0.0;
    for (uint i = 0u; i < gi.counts.x; ++i) {
        vec3 d = normalize(tbn * gi.cones[i].xyz);
        ConeResult c = trace_cone(g, d, gi.cone_tan[i].x, 1e30);
        sum += gi.cones[i].w * c.radiance;
        occlusion += gi.cones[i].w * c.occlusion;
    }
    return vec4(sum, clamp(1.0 - occlusion, 0.0, 1.0));
}

#endif
