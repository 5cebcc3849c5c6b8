// Voxel cone tracing, shared by the per-pixel tracer, the bounce pass and the mip view.
// The including shader declares, before including this file (GiParams is in cone_params.glsl):
//   uniform GridBlock { VoxelGrid grid; };        uniform GiBlock { GiParams gi; };
//   uniform sampler3D vox_lod0;                   (full-resolution radiance, RGBA16F; bricked,
//                                                  its pool, 9^3 per brick)
//   uniform sampler3D aniso[6];                   (+x, -x, +y, -y, +z, -z directional volumes:
//                                                  their dense levels, bricks.glsl)
//   layout(r32ui) uniform readonly uimage3D brick_maps[4];
//   uniform texture3D aniso_pool[18];             (pooled directional levels: 6 per level)
//   uniform sampler pool_sampler;
// and, where cones see the sky (`#define CONE_SKY` before including), FrameBlock { FrameData
// frame; }, uniform sampler2D sky_cones and sky_irradiance (sky.glsl).
// Positions are in voxel units: 0..res along each axis of the grid.
#ifndef DVSGI_CONE_GLSL
#define DVSGI_CONE_GLSL
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "voxel.glsl"
#include "bricks.glsl"
#include "cone_params.glsl"
#ifdef CONE_SKY
#include "sky.glsl"
#endif

// Every call site of a function is a copy of it in the compiled shader (GLSL inlines calls).
// The cone step calls the voxel sampler once per part of its footprint (one; four quarters;
// or four quarters' shares and the whole) and the directional sampler once per level it
// blends (one or two), each in a SAMPLER_LOOP. build.rs compiles each shader that traces
// cones twice:
// * as it stands, for CPU drivers: the loops are kept, so the sampler is one copy, which
//   lavapipe compiles on a machine's first frame in a third of the time (BENCHMARKS.md, "What the
//   cone tracer costs to compile");
// * with CONE_SAMPLERS_UNROLLED, for GPUs: the loops are marked for unrolling (SPIR-V's Unroll
//   loop control, a hint to the driver's compiler). Kept loops made the H200's cone trace
//   1.5x slower; marked, it takes back 0.6 of that (BENCHMARKS.md, "NVIDIA H200 at 6be6713").
// Both give the same images (tests/repeat.rs).
#ifdef CONE_SAMPLERS_UNROLLED
#define SAMPLER_LOOP [[unroll]]
#else
#define SAMPLER_LOOP [[dont_unroll]]
#endif

// Directional volume `face` (literal) of pooled level l (0..2) at normalized pool
// coordinates q: trilinear within one brick (every face's pool has the same layout).
#define POOLED_FACE(face, l, q)                                                                  \
    (l == 0 ? pooled_texel(aniso_pool[face], q)                                                   \
            : (l == 1 ? pooled_texel(aniso_pool[6 + face], q) : pooled_texel(aniso_pool[12 + face], q)))

vec4 pooled_texel(texture3D pool_image, vec3 q) {
    return textureLod(sampler3D(pool_image, pool_sampler), q, 0.0);
}

bool layers() {
    return (gi.counts.w & GI_FLAG_LAYERS) != 0u;
}

// The optical depth of an occupied full-resolution voxel (voxel.glsl).
float opaque_tau() {
    return layers() ? LAYER_TAU : VOXEL_TAU;
}

// The three directional volumes a cone travelling along `dir` samples (x, y, z: the volume of
// each axis on the side dir points to, each (L * tau, tau) per texel along its axis), as one
// (L * tau, tau) per texel along dir. gi.opacity:
// * "blend": averaged by the squared components of dir. A wall across axis a crossed at
//   angle theta from a holds tau_a cos(theta) along the path: oblique cones leak through it.
// * "layers": tau = |(|d_x| tau_x, |d_y| tau_y, |d_z| tau_z)|. A wall across a is crossed over
//   1 / |d_a| texels along the path at |d_a| tau_a per texel: its whole optical depth at any
//   angle; isotropic cover (tau_a all equal) keeps its tau. Each axis's radiance is weighted
//   by its share of the sum of squares.
vec4 axis_blend(vec4 x, vec4 y, vec4 z, vec3 dir) {
    vec3 w = dir * dir;
    if (!layers()) return (x * w.x + y * w.y + z * w.z) / max(w.x + w.y + w.z, 1e-12);
    vec3 tau = max(vec3(x.a, y.a, z.a), vec3(0.0));
    vec3 share = w * tau * tau;
    float sum = share.x + share.y + share.z;
    if (sum <= 0.0) return vec4(0.0);
    // (L_a tau_a) w_a tau_a = L_a share_a.
    vec3 weighted = max(x.rgb, vec3(0.0)) * (w.x * tau.x) + max(y.rgb, vec3(0.0)) * (w.y * tau.y)
                  + max(z.rgb, vec3(0.0)) * (w.z * tau.z);
    float rate = sqrt(sum);
    return vec4(weighted / sum * rate, rate);
}

// The directional volumes at level l, blended by the squared components of `dir` (the
// direction the cone travels): the volume integrated along +x serves cones going +x. A dense
// level (l >= the pooled levels) is sampled at lod `d` of the dense images: l minus the pooled
// levels, or between it and the next (the sampler blends dense levels).
vec4 anisotropic_level(vec3 uvw, vec3 dir, int l, float d) {
    vec4 x, y, z;
    if (l >= int(grid.dims.y)) {
        x = dir.x >= 0.0 ? textureLod(aniso[0], uvw, d) : textureLod(aniso[1], uvw, d);
        y = dir.y >= 0.0 ? textureLod(aniso[2], uvw, d) : textureLod(aniso[3], uvw, d);
        z = dir.z >= 0.0 ? textureLod(aniso[4], uvw, d) : textureLod(aniso[5], uvw, d);
    } else {
        // One map lookup serves the three faces.
        vec4 p = level_lookup(l + 1, uvw * float(pool_level_side(l + 1)));
        if (p.w == 0.0) return vec4(0.0);
        vec3 q = p.xyz / vec3(grid.pools[l + 1].xyz * 9u);
        x = dir.x >= 0.0 ? POOLED_FACE(0, l, q) : POOLED_FACE(1, l, q);
        y = dir.y >= 0.0 ? POOLED_FACE(2, l, q) : POOLED_FACE(3, l, q);
        z = dir.z >= 0.0 ? POOLED_FACE(4, l, q) : POOLED_FACE(5, l, q);
    }
    return axis_blend(x, y, z, dir);
}

// The directional volumes at fractional `level`, blended by the squared components of `dir`.
// Returns (L * tau, tau) (voxel.glsl). Dense levels blend between levels in the sampler (one
// lookup); pooled ones (one image per level) here, the two levels in a SAMPLER_LOOP that calls
// anisotropic_level once.
vec4 sample_anisotropic(vec3 uvw, vec3 dir, float level) {
    int pooled = int(grid.dims.y);
    bool dense = float(pooled) <= level;
    int l = dense ? pooled : int(floor(level));
    float f = dense ? 0.0 : level - float(l);
    vec4 a = vec4(0.0);
    SAMPLER_LOOP for (int k = 0; k < 2; ++k) {
        if (k == 1 && !(f > 0.0)) break;
        vec4 v = anisotropic_level(uvw, dir, l + k, dense ? level - float(pooled) : float(l + k - pooled));
        a = k == 0 ? v : mix(a, v, f);
    }
    return a;
}

// The full-resolution radiance, trilinear, one hardware lookup in both layouts: bricked, in
// the brick whose 9^3 texels (apron included) hold the whole filter, found by one map lookup.
vec4 sample_full(vec3 uvw) {
    if (!bricked()) return textureLod(vox_lod0, uvw, 0.0);
    vec4 p = level_lookup(0, uvw * float(grid.dims.x));
    if (p.w == 0.0) return vec4(0.0);
    return textureLod(vox_lod0, p.xyz / vec3(grid.pools[0].xyz * 9u), 0.0);
}

// gi.cone_filter = "two-tap" (voxel.glsl). A texel holds what a path through it along its axis meets: the
// opacity composited along the axis and averaged across it (aniso_mip.comp). A sample at
// texel coordinate u between two texel centres along the axis takes one tap on each centre
// plane, so the sampler filters each only across the axis (bilinear) and opacity, which is
// what partial coverage across averages, is what it filters. The two taps are then blended
// in optical depth, which is what adds along the path: a thin wall split between two samples
// arrives whole, and a surface covering part of the footprint occludes that part, not all of
// it. Positions in texels of the level; `at` is the sample's coordinate along the axis.
struct AlongTaps {
    float first;   // the lower centre plane's coordinate, texels
    float weight;  // the upper plane's share
};

AlongTaps along_taps(float at) {
    float below = floor(at - 0.5);
    return AlongTaps(below + 0.5, at - 0.5 - below);
}

vec4 blend_along(vec4 lower, vec4 upper, float weight) {
    return mix(tau_from_alpha(lower, opaque_tau()), tau_from_alpha(upper, opaque_tau()), weight);
}

// Volume `v` at its level d (`side` texels a side), `axis` its direction's axis, at normalized uvw.
vec4 dense_along(sampler3D v, vec3 uvw, int axis, int d, float side) {
    AlongTaps t = along_taps(uvw[axis] * side);
    vec3 a = uvw, b = uvw;
    a[axis] = t.first / side;
    b[axis] = (t.first + 1.0) / side;
    return blend_along(textureLod(v, a, float(d)), textureLod(v, b, float(d)), t.weight);
}

// The same for pooled level l: `p` is the sample's pool texel position (level_lookup) and `at`
// its coordinate along the axis in the level's texels; the two taps stay in p's brick.
// `taps` = along_taps(at).
#define POOLED_ALONG(face, axis, l, p, at, taps, inv_pool)                                         \
    blend_along(POOLED_FACE(face, l, shifted(p, axis, taps.first - (at), inv_pool)),              \
                POOLED_FACE(face, l, shifted(p, axis, taps.first + 1.0 - (at), inv_pool)), taps.weight)

vec3 shifted(vec3 p, int axis, float by, vec3 inv_pool) {
    p[axis] += by;
    return p * inv_pool;
}

// Two-tap: the directional volumes at integer level l, blended by the squared components of
// `dir` as anisotropic_level does. Returns (L * tau, tau).
vec4 two_tap_level(vec3 uvw, vec3 dir, int l) {
    int pooled = int(grid.dims.y);
    vec4 x, y, z;
    if (l >= pooled) {
        int d = l - pooled;
        float side = float(int(grid.dims.x) >> (l + 1));
        x = dir.x >= 0.0 ? dense_along(aniso[0], uvw, 0, d, side) : dense_along(aniso[1], uvw, 0, d, side);
        y = dir.y >= 0.0 ? dense_along(aniso[2], uvw, 1, d, side) : dense_along(aniso[3], uvw, 1, d, side);
        z = dir.z >= 0.0 ? dense_along(aniso[4], uvw, 2, d, side) : dense_along(aniso[5], uvw, 2, d, side);
    } else {
        // One map lookup serves the three faces.
        vec3 pos = uvw * float(pool_level_side(l + 1));
        vec4 p = level_lookup(l + 1, pos);
        if (p.w == 0.0) return vec4(0.0);
        vec3 inv_pool = 1.0 / vec3(grid.pools[l + 1].xyz * 9u);
        AlongTaps tx = along_taps(pos.x), ty = along_taps(pos.y), tz = along_taps(pos.z);
        x = dir.x >= 0.0 ? POOLED_ALONG(0, 0, l, p.xyz, pos.x, tx, inv_pool)
                         : POOLED_ALONG(1, 0, l, p.xyz, pos.x, tx, inv_pool);
        y = dir.y >= 0.0 ? POOLED_ALONG(2, 1, l, p.xyz, pos.y, ty, inv_pool)
                         : POOLED_ALONG(3, 1, l, p.xyz, pos.y, ty, inv_pool);
        z = dir.z >= 0.0 ? POOLED_ALONG(4, 2, l, p.xyz, pos.z, tz, inv_pool)
                         : POOLED_ALONG(5, 2, l, p.xyz, pos.z, tz, inv_pool);
    }
    return axis_blend(x, y, z, dir);
}

// Two-tap: the directional volumes at fractional `level`, the two integer levels blended in
// optical depth.
vec4 two_tap_directional(vec3 uvw, vec3 dir, float level) {
    int l = int(floor(level));
    float f = level - float(l);
    vec4 a = vec4(0.0);
    SAMPLER_LOOP for (int k = 0; k < 2; ++k) {
        if (k == 1 && !(f > 0.0)) break;
        vec4 v = two_tap_level(uvw, dir, l + k);
        a = k == 0 ? v : mix(a, v, f);
    }
    return a;
}

// Opacity of an occupied full-resolution voxel: optical depth opaque_tau().
float voxel_alpha() {
    return layers() ? 1.0 - 1.0 / 65536.0 : 1.0 - 1.0 / 256.0;
}

// Two-tap: the full-resolution radiance (L, occupancy; premultiplied) as (L * tau, tau): two
// taps along the axis the cone travels most along, as for the directional volumes. Bricked, both
// taps are in the brick whose 9^3 texels (apron included) hold the whole filter, found by
// one map lookup.
vec4 two_tap_full(vec3 uvw, vec3 dir) {
    vec3 m = abs(dir);
    int axis = m.x >= m.y && m.x >= m.z ? 0 : (m.y >= m.z ? 1 : 2);
    float res = float(grid.dims.x);
    vec3 pos = uvw * res;
    AlongTaps t = along_taps(pos[axis]);
    vec3 a = pos, b = pos;
    a[axis] = t.first;
    b[axis] = t.first + 1.0;
    vec3 scale = vec3(1.0 / res);
    if (bricked()) {
        vec4 p = level_lookup(0, pos);
        if (p.w == 0.0) return vec4(0.0);
        a += p.xyz - pos;
        b += p.xyz - pos;
        scale = 1.0 / vec3(grid.pools[0].xyz * 9u);
    }
    vec4 lower = textureLod(vox_lod0, a * scale, 0.0) * voxel_alpha();
    vec4 upper = textureLod(vox_lod0, b * scale, 0.0) * voxel_alpha();
    return blend_along(lower, upper, t.weight);
}

// Quadrilinear sample at voxel-space position g and level of detail `lod` (log2 of the
// texel size in voxels): below 1 the full-resolution volume blends into the directional
// volumes' level 0 (which is lod 1); above, the directional mips blend trilinearly. Two-tap
// filtering (gi.cone_filter) takes two lookups where trilinear takes one.
// Returns (L * tau, tau): radiance weighted by optical depth across one texel.
vec4 sample_voxels(vec3 g, vec3 dir, float lod) {
    vec3 uvw = g / float(grid.dims.x);
    float top = float(gi.counts.z);  // lod of the last directional level + 1
    lod = clamp(lod, 0.0, top);
    bool two_tap = (gi.counts.w & GI_FLAG_TWO_TAP) != 0u;
    // Each sampler is called at one place (SAMPLER_LOOP says why).
    vec4 full = vec4(0.0);
    if (lod < 1.0) {
        // Occupied full-resolution voxels (radiance L, alpha 1) have optical depth opaque_tau().
        full = two_tap ? two_tap_full(uvw, dir) : sample_full(uvw) * opaque_tau();
        if (lod <= 0.0) return full;
    }
    float level = max(lod - 1.0, 0.0);
    vec4 directional = two_tap ? two_tap_directional(uvw, dir, level) : sample_anisotropic(uvw, dir, level);
    return lod >= 1.0 ? directional : mix(full, directional, lod);
}

// What a path of `depth` texels through sample `smp` (L * tau, tau) adds: premultiplied
// radiance and opacity (c, alpha).
vec4 cone_segment(vec4 smp, float depth) {
    float tau = max(smp.a, 0.0);
    if (tau <= 0.0) return vec4(0.0);
    float a = 1.0 - exp(-tau * depth);
    return vec4(max(smp.rgb, vec3(0.0)) / tau * a, a);
}

// What a cone has met so far beyond its current step (trace_cone), by gi.footprint:
// * "whole": nothing (the caller composites each step).
// * "quadrants": `parts` is each quarter's transmittance.
// * "shares": `parts` is the largest share of each quarter of the footprint that the cone has
//   met covered, and `path` the transmittance the rest has composited along the path.
struct Footprint {
    vec4 parts;
    float path;
};

// gi.footprint = "shares": the share of the footprint its quarters' covers leave open.
float shares_open(vec4 share) {
    return 1.0 - dot(share, vec4(0.25));
}

// The transmittance a cone's footprint has left (1 for "whole", whose caller composites it).
float footprint_transmittance(uint kind, Footprint fp) {
    if (kind == GI_FLAG_QUADRANTS) return dot(fp.parts, vec4(0.25));
    if (kind == GI_FLAG_SHARES) return fp.path * shares_open(fp.parts);
    return 1.0;
}

// The two axes across `dir` for the quarters' shares: the first is the grid axis `dir` leans
// along least, made perpendicular to it, so the quarters of a cone that runs along a grid axis
// split the footprint along the grid's walls.
mat3 footprint_frame(vec3 dir) {
    vec3 m = abs(dir);
    vec3 e = m.x <= m.y && m.x <= m.z ? vec3(1.0, 0.0, 0.0) : (m.y <= m.z ? vec3(0.0, 1.0, 0.0) : vec3(0.0, 0.0, 1.0));
    vec3 a = normalize(e - dot(e, dir) * dir);
    return mat3(a, cross(dir, a), dir);
}

// One step of a cone: what a path of `step_len` voxels through the footprint of texel side s
// at p adds, (premultiplied radiance, opacity), relative to the transmittance the cone had
// before, so the caller composites it as one segment (cone_segment).
//
// gi.footprint = "quadrants" (`quarters`): the footprint (diameter 2s across the cone) as four
// samples of side s/2, one on each quarter, each quarter compositing its own transmittance
// `fp.parts` along the path (so each step is beta times a quarter's diameter, s: trace_cone).
// What covers one part of the footprint stays in that part: a wall beside the cone's axis that
// sample after sample covers in part blocks the quarters it covers once, rather than a little
// more of the whole footprint at every sample; and a side wall and a roof that cover different
// parts leave no part open. Each quarter is a narrower cone from the same apex, its axis
// tan_half / 2 off the cone's toward its quarter: it samples the directional volumes along
// that axis, so a quarter that drifts across a wall beside the cone crosses it as its rays do
// (seen along the cone's own axis, a wall parallel to it is only as opaque as its share of the
// texel). Below s = 2 (quarters of texels under a voxel) the quarters share the whole
// footprint's one sample.
//
// gi.footprint = "shares": steps as long as "whole"'s, each taking first one sample per quarter
// of the footprint (side s/2, at its centre, along the cone), whose opacity over one texel is
// the share of that quarter something covers (the volumes average opacity across their axis:
// aniso_mip.comp), then the whole footprint's sample. Each quarter keeps the largest share it
// has met (`fp.parts`): a wall beside the cone is counted once, however many steps it runs
// along, and what a quarter's share gains adds the quarters' radiance through the
// transmittance before it. The whole footprint's opacity beyond the quarters' mean share at
// this step is what the open part meets along the path (`fp.path`: what crosses the cone). The
// cone's transmittance is path * shares_open. Largest shares assume that cover which comes and
// goes in a quarter (leaves) is the same cover each time. Below s = 2 there are no quarters.
//
// One call of sample_voxels, in a SAMPLER_LOOP over the parts (one, four, or five).
vec4 footprint_segment(vec3 p, vec3 dir, float tan_half, mat3 across, float s, float step_len, uint kind,
                       inout Footprint fp) {
    bool quarters = kind == GI_FLAG_QUADRANTS, split = kind == GI_FLAG_SHARES;
    float before = footprint_transmittance(kind, fp);
    if (before <= 0.0) return vec4(0.0);
    int parts = quarters && s >= 2.0 ? 4 : (split && s >= 2.0 ? 5 : 1);
    float q = parts == 1 ? s : 0.5 * s;
    vec3 radiance = vec3(0.0), beside = vec3(0.0);
    vec4 shares = fp.parts;
    float covered = 0.0;  // "shares": the quarters' mean share at this step
    SAMPLER_LOOP for (int k = 0; k < 5; ++k) {
        if (k >= parts) break;
        // "shares": taps 0..3 on the quarters, then (k = 4, or alone) the whole footprint.
        bool tap = parts == 5 && k < 4;
        vec3 pk = p, dk = dir;
        float lod = log2(q), depth = step_len / q;
        if (parts == 4) {
            vec2 side = vec2((k & 1) == 0 ? -q : q, (k & 2) == 0 ? -q : q);
            pk = p + across[0] * side.x + across[1] * side.y;
            dk = normalize(dir + (across[0] * sign(side.x) + across[1] * sign(side.y)) * (0.5 * tan_half));
        } else if (tap) {
            pk = p + across[0] * ((k & 1) == 0 ? -q : q) + across[1] * ((k & 2) == 0 ? -q : q);
            depth = 1.0;
        } else if (parts == 5) {
            lod = log2(s);
            depth = step_len / s;
        }
        vec4 seg = cone_segment(sample_voxels(pk, dk, lod), depth);
        if (!quarters && !split) return seg;
        if (quarters) {
            if (parts == 1) {
                radiance = before * seg.rgb;
                fp.parts *= 1.0 - seg.a;
            } else {
                radiance += 0.25 * fp.parts[k] * seg.rgb;
                fp.parts[k] *= 1.0 - seg.a;
            }
        } else if (tap) {
            covered += 0.25 * seg.a;
            float gain = max(seg.a - shares[k], 0.0);
            shares[k] += gain;
            // The quarter's radiance (seg.rgb is premultiplied by seg.a), by its gain in share.
            if (gain > 0.0) beside += seg.rgb / seg.a * gain;
        } else {
            float open = shares_open(fp.parts), now = shares_open(shares);
            float gained = dot(shares - fp.parts, vec4(1.0));
            // What the quarters' gains close, lit by their walls' mean radiance.
            if (gained > 0.0) radiance += fp.path * (open - now) * beside / gained;
            // The whole footprint's cover beyond what the quarters see at this step is what
            // the open part meets along the path (the quarters' own is counted in their
            // shares, once).
            float a = seg.a > 0.0 && covered < 1.0 ? clamp((seg.a - covered) / (1.0 - covered), 0.0, 1.0) : 0.0;
            if (a > 0.0) radiance += fp.path * now * seg.rgb / seg.a * a;
            fp.path *= 1.0 - a;
            fp.parts = shares;
        }
    }
    return vec4(radiance, before - footprint_transmittance(kind, fp)) / before;
}

struct ConeResult {
    vec3 radiance;    // radiance arriving along the cone from the voxels (front-to-back composited)
    float opacity;    // accumulated opacity
    float occlusion;  // opacity weighted by f(r) = 1 / (1 + falloff r), for ambient occlusion
    float sky;        // the transmittance it leaves the grid with (0 when it ends inside)
};

// Where a cone starts: a surface point, its unit normal, and how far (in units of |n|_1)
// the surface's own voxels may reach beyond that point along n: 0 for a point on the
// surface, 0.5 for a voxel centre (the surface passes somewhere through the voxel).
struct ConeOrigin {
    vec3 p;  // voxel units
    vec3 n;
    float layer;
};

// Every sample of a texel of side s (voxels) filters texels whose centres lie within s of it
// on each axis, and a texel holding any voxel of the origin's surface has its centre within
// s/2 |n|_1 of the surface. A sample at height h above the surface (along n) therefore sees
// none of the surface's own voxels while h >= (SELF_CLEARANCE s + layer) |n|_1.
const float SELF_CLEARANCE = 1.5;

// The largest texel side (a power of two, >= 1) a sample at height h may filter without
// touching the origin's own voxels. A power of two, so the coarser level of a quadrilinear
// blend obeys it too.
float clear_texel(ConeOrigin o, float l1, float h) {
    return exp2(floor(log2(max((h / l1 - o.layer) / SELF_CLEARANCE, 1.0))));
}

// March a cone from origin o along unit `dir` with half-aperture tangent `tan_half` up to
// `max_t` voxels from the surface point:
// * It starts where a full-resolution sample clears the origin's own voxels (plus
//   gi.start_offset), and each sample filters texels of side s = half the cone's diameter
//   (a trilinear texel of side s spreads over the same variance, s^2/4 per axis, as the
//   cone's disc of diameter 2s), but never more than `clear_texel` allows: near the surface
//   a wide cone samples a narrower footprint rather than its own surface. So no sample sees
//   the surface it starts from, at any resolution.
// * Steps are gi.step (beta) times the diameter, i.e. 2 beta texels; optical depth is summed
//   over each step (voxel.glsl), so nothing leaks through walls between samples. With
//   gi.footprint = "quadrants" the diameter is a quarter's (footprint_segment).
// * It ends at max_t, when opaque, or when its filter footprint has left the grid (which is
//   transparent outside: nothing there is known to emit).
// * A cone whose end lies outside the grid has left the scene: `sky` is the transmittance it
//   has left, through which it sees the sky beyond (cone_sky, trace_diffuse). One that ends
//   inside (at max_t, or opaque) sees none: where the scene's walls close, no sky gets in.
ConeResult trace_cone(ConeOrigin o, vec3 dir, float tan_half, float max_t) {
    ConeResult r;
    r.radiance = vec3(0.0);
    r.opacity = 0.0;
    r.occlusion = 0.0;
    r.sky = 0.0;
    float res = float(grid.dims.x);
    float beta = max(gi.trace.x, 0.01);
    float falloff = gi.trace.w;
    tan_half = clamp(tan_half, 1e-4, 20.0);
    max_t = min(max_t, gi.trace.y);
    float l1 = abs(o.n.x) + abs(o.n.y) + abs(o.n.z);
    float h0 = l1 * (SELF_CLEARANCE + o.layer) + gi.trace.z;
    vec3 g = o.p + o.n * h0;
    float rise = dot(dir, o.n);  // height gained per voxel along the cone
    // max_t is measured from the surface point; the cone starts h0 off it.
    max_t -= h0 * max(rise, 0.0);
    // gi.footprint: what the cone has met across its footprint (Footprint).
    uint kind = gi.counts.w & (GI_FLAG_QUADRANTS | GI_FLAG_SHARES);
    bool quarters = kind == GI_FLAG_QUADRANTS;
    Footprint fp = Footprint(vec4(quarters ? 1.0 : 0.0), 1.0);
    mat3 across = kind == GI_FLAG_SHARES ? footprint_frame(dir) : tangent_frame(dir);
    float t = 0.0;
    for (int i = 0; i < 1024 && t < max_t && r.opacity < 0.995; ++i) {
        vec3 p = g + dir * t;
        float s = max(1.0, tan_half * t);
        if (any(lessThan(p, vec3(-1.5 * s))) || any(greaterThan(p, vec3(res + 1.5 * s)))) break;
        s = min(s, clear_texel(o, l1, h0 + t * max(rise, 0.0)));
        float step_len = 2.0 * beta * (quarters && s >= 2.0 ? 0.5 * s : s);
        vec4 seg = footprint_segment(p, dir, tan_half, across, s, step_len, kind, fp);
        if (seg.a > 0.0) {
            r.radiance += (1.0 - r.opacity) * seg.rgb;
            r.occlusion += (1.0 - r.occlusion) * seg.a / (1.0 + falloff * t);
            r.opacity += (1.0 - r.opacity) * seg.a;
        }
        t += step_len;
    }
    if (kind != 0u) r.opacity = 1.0 - footprint_transmittance(kind, fp);
    vec3 end = g + dir * t;
    if (any(lessThan(end, vec3(0.0))) || any(greaterThan(end, vec3(res)))) r.sky = 1.0 - r.opacity;
    r.radiance = min(r.radiance, vec3(HALF_MAX));
    return r;
}

#ifdef CONE_SKY
// What a cone of half-aperture tangent `tan_half` along `dir` sees of the sky past the voxels
// (c = trace_cone's result), in the volumes' scaled radiance.
vec3 cone_sky(ConeResult c, vec3 dir, float tan_half) {
    if (c.sky <= 0.0) return vec3(0.0);
    return c.sky * sky_cone(sky_cones, frame.sky, dir, tan_half) * grid.params.y;
}
#endif

// Diffuse cones over the hemisphere of the origin's normal: the cosine-weighted
// mean incoming radiance (irradiance / pi) in rgb and the AO factor (1 = unoccluded) in a.
// With CONE_SKY the sky seen past the voxels is added: each cone's sky, filtered to its
// aperture, through the transmittance it left the grid with, and the sum scaled so that with
// nothing in the way it is the sky's exact irradiance / pi at the normal (sky.glsl): a few
// cones' weights do not integrate a small bright source (a sun in the image) exactly.
vec4 trace_diffuse(ConeOrigin o) {
    mat3 tbn = tangent_frame(o.n);
    vec3 sum = vec3(0.0);
    float occlusion = 0.0;
    vec3 sky_seen = vec3(0.0), sky_open = vec3(0.0);
    for (uint i = 0u; i < gi.counts.x; ++i) {
        vec3 d = normalize(tbn * gi.cones[i].xyz);
        ConeResult c = trace_cone(o, d, gi.cone_tan[i].x, 1e30);
        sum += gi.cones[i].w * c.radiance;
        occlusion += gi.cones[i].w * c.occlusion;
#ifdef CONE_SKY
        if (has_sky(frame.sky)) {
            vec3 sky = gi.cones[i].w * sky_cone(sky_cones, frame.sky, d, gi.cone_tan[i].x);
            sky_open += sky;
            sky_seen += c.sky * sky;
        }
#endif
    }
#ifdef CONE_SKY
    if (has_sky(frame.sky)) {
        vec3 exact = sky_irradiance_over_pi(sky_irradiance, frame.sky, o.n);
        vec3 k = vec3(sky_open.r > 0.0 ? exact.r / sky_open.r : 1.0, sky_open.g > 0.0 ? exact.g / sky_open.g : 1.0,
                      sky_open.b > 0.0 ? exact.b / sky_open.b : 1.0);
        sum = min(sum + sky_seen * k * grid.params.y, vec3(HALF_MAX));
    }
#endif
    return vec4(sum, clamp(1.0 - occlusion, 0.0, 1.0));
}

#endif
