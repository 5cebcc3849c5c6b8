// The voxel grid (mirrors render::voxel::GpuVoxelGrid) and helpers shared by every voxel pass.
#ifndef DVSGI_VOXEL_GLSL
#define DVSGI_VOXEL_GLSL

struct VoxelGrid {
    vec4 origin;     // xyz world position of the grid's min corner, w voxel size (world units)
    uvec4 dims;      // x voxels per side; y directional levels in brick pools (bricks.glsl);
                     // z 1 when the volumes are bricked, 0 when dense; w the fixed-point
                     // one of the voxelization sums (sum_sample below)
    vec4 params;     // x emission scale: voxels store emission / scale in 8 bits;
                     // y radiance scale: radiance volumes hold radiance * y; z = 1/y;
                     // w gi.voxel_cover: 0 "touch", 1 "area", 2 "directional"
                     // (AREA_COVER, DIRECTIONAL_COVER)
    uvec4 pools[4];  // brick pools (render::bricks): xyz slots per axis of the pool image,
                     // w bricks per side of its map; 0 full resolution, 1.. directional levels
};

// Opacity in the cone-traced volumes. A directional texel describes what a path through it
// along its axis meets: the opacity composited along the axis and averaged across it
// (aniso_mip.comp), so a surface covering part of the texel's cross-section counts as that
// part. It is stored in one of two forms, as gi.cone_filter asks (cone.glsl):
// * "trilinear": (L * tau, tau), optical depth tau = -ln(1 - alpha) and the radiance L
//   weighted by it. Optical depth adds along a path and is linear under filtering, so a thin
//   opaque wall stays opaque however the trilinear weights of successive cone samples split
//   it (interpolating opacity lets ~1/6 of the light through every wall). But the filter also
//   blends optical depth across the cone, where opacity is what averages: a footprint that a
//   surface covers in part comes out nearly opaque.
// * "two-tap": premultiplied (c, alpha). Each cone sample filters opacity across the axis and
//   blends optical depth along it, each where it belongs.
// An occupied full-resolution voxel is opaque: optical depth VOXEL_TAU (transmittance 1/256),
// or with gi.opacity = "layers" LAYER_TAU (1/65536), which is also the most any texel holds.
const float VOXEL_TAU = 5.545177;  // ln(256)
const float LAYER_TAU = 11.090355;  // ln(65536)

// Premultiplied (c, alpha) -> (L * tau, tau), tau at most `opaque`, and back.
vec4 tau_from_alpha(vec4 premultiplied, float opaque) {
    float a = clamp(premultiplied.a, 0.0, 1.0);
    if (a <= 0.0) return vec4(0.0);
    float tau = min(-log(max(1.0 - a, 1e-30)), opaque);
    return vec4(max(premultiplied.rgb, vec3(0.0)) / a * tau, tau);
}

vec4 alpha_from_tau(vec4 texel) {
    float tau = max(texel.a, 0.0);
    if (tau <= 0.0) return vec4(0.0);
    float a = 1.0 - exp(-tau);
    return vec4(max(texel.rgb, vec3(0.0)) / tau * a, a);
}

// Voxel volumes store RGB in 8 bits each plus an 8-bit sample count (R32_UINT, for atomics).
uint pack_rgb_count(vec3 rgb255, float count) {
    uvec4 b = uvec4(clamp(round(vec4(rgb255, count)), 0.0, 255.0));
    return b.r | (b.g << 8) | (b.b << 16) | (b.a << 24);
}

vec4 unpack_rgb_count(uint v) {
    return vec4(float(v & 0xffu), float((v >> 8) & 0xffu), float((v >> 16) & 0xffu), float(v >> 24));
}

// Order-independent voxelization. Every sample a voxel receives (one per triangle whose
// fragment column touches it) is added, as integers, to the voxel's sums: a count, and each
// attribute channel clamped to [0,1] in fixed point with grid.dims.w steps. Integer
// additions commute, so the sums, and the averages voxel_resolve.comp makes of them, do not
// depend on the order fragments arrive in. grid.dims.w is chosen (render::voxel::sum_scale)
// so that no sum can overflow: a voxel receives at most one sample per drawn triangle.
// The sums are R32_UINT volumes of the full-resolution extent (pool 0 with bricks), one per
// word: SUM_COUNT, then three per attribute (SUM_ALBEDO, SUM_NORMAL), one for the surface's
// offset (SUM_OFFSET, below), three for SUM_EMISSION, one for the surfaces' cover
// (SUM_COVER, below) and twenty-four for the normals seen from each side (SUM_SIDES, below). The
// emission's words exist only with emission, the cover's only with gi.voxel_cover = "area",
// the sides' only with gi.attenuation = "per-side" (render::voxel::sum_word_indices); a
// placeholder, never touched, is bound in their place otherwise.
const int SUM_COUNT = 0;
const int SUM_ALBEDO = 1;
const int SUM_NORMAL = 4;
const int SUM_OFFSET = 7;
const int SUM_EMISSION = 8;
const int SUM_COVER = 11;
const int SUM_SIDES = 12;
const int SUM_WORDS = 36;

// How much of a voxel its surfaces cover (gi.voxel_cover): "touch" (every voxel a triangle
// touches is opaque, the conservative voxelization) or "area" (grid.params.w = 1).
// With "area" each sample adds the share of the voxel's cross-section its triangle covers,
// across the triangle's dominant axis: the part of the fragment's pixel square the triangle
// covers (its footprint), clipped to the voxel's slab of the column. Of the voxels one fragment
// touches, the one holding the largest share takes the whole footprint, so a surface that
// crosses a column stays opaque along it wherever the column splits it (watertight); the
// others keep their own share, and a voxel a surface only grazes (an edge, a corner, the top
// of a curtain) is that much opaque, not wholly. The voxel's opacity is the sum of its
// samples' cover, at most 1, stored in place of the albedo volume's count (a code of 1..255,
// so 0 still means empty), and the radiance volumes hold (L * cover, cover), premultiplied.
// (A macro: the shaders that include this file declare `grid` after it.)
#define AREA_COVER (grid.params.w > 0.5)
// gi.voxel_cover = "directional" (with AREA_COVER): seen along axis a a voxel covers its cover
// times directional_share(n, a) (aniso_mip.comp).
#define DIRECTIONAL_COVER (grid.params.w > 1.5)

// How much of a voxel's cover is seen along axis a, from its surfaces' mean normal n (|n| <= 1):
// a plane of area A in the voxel covers A |n_a| of the face across a, and its cover (the share
// across its dominant axis d) is A |n_d|, so the share along a is |n_a| / |n_d|. Where the
// normals disagree (|n| < 1/2: both sides of a thin slab, a corner's faces) the surfaces are
// not one plane, and the voxel is as opaque along every axis.
float directional_share(vec3 n, int a) {
    vec3 m = abs(n);
    float top = max(m.x, max(m.y, m.z));
    if (dot(n, n) < 0.25 || top <= 0.0) return 1.0;
    return m[a] / top;
}

// gi.attenuation = "per-side" (voxel_light.comp, aniso_mip.comp). A voxel whose mean normal is
// at least this long holds one plane, or faces within about 50 degrees of each other (two
// faces of equal area at angle t give cos(t/2)), which the mean normal's cosine lights right
// from every side; a shorter one holds faces that face different ways (an edge, a corner, both
// sides of a thin slab), each lit by its own cosine.
const float ONE_PLANE = 0.9;

// The six side factors of a voxel (side j faces +x, -x, +y, -y, +z, -z for j = 0..5): the light
// of its faces seen from that side (side_normal below) over the light of its mean normal, each
// in 5 bits as k * 16, so 0..1.9375 in steps of 1/16; 16 (1) where nothing changes.
uint pack_sides(float k[6]) {
    uint word = 0u;
    for (int j = 0; j < 6; ++j) word |= uint(round(clamp(k[j], 0.0, 31.0 / 16.0) * 16.0)) << (5 * j);
    return word;
}

float side_factor(uint word, int j) {
    return float((word >> (5 * j)) & 31u) / 16.0;
}

// What a voxel's faces look like from each side (gi.attenuation = "per-side"): side j's normal
// is the mean of the normals of the samples that face it (n.s > 0), each weighted by w = n.s,
// the share of its area seen from that side: m = sum(w n) / sum(w), shorter than 1 where those
// faces differ. Where they are all lit, m.wi is exactly the mean of their cosines weighted by
// what the side sees of them, so a curved surface seen from the side shows its tilted faces,
// lit as they are lit, and a face seen edge-on adds nothing. The voxelization sums each
// sample's (w n, w) for its sides (at most three, one per axis it is not parallel to) in the
// four words from SUM_SIDES + 4 j, signed: halved, in fixed point, added as two's complement,
// so a sum of at most one sample per drawn triangle stays within 32 bits
// (render::voxel::sum_scale). voxel_resolve.comp divides them and packs the six in a uvec4
// (pack_side_normal). A side whose samples' weights add to less than SIDE_SEEN of the voxel's
// samples' count has none: the voxel light gives it the light of a face along the side's axis.
const float SIDE_SEEN = 0.05;

// Side j's axis direction (j = 0..5: +x, -x, +y, -y, +z, -z).
vec3 side_axis(int j) {
    vec3 s = vec3(0.0);
    s[j / 2] = (j & 1) == 0 ? 1.0 : -1.0;
    return s;
}

// gi.plane_backs (aniso_mip.comp, voxel_backs.comp). The plane a voxel of mean normal n holds:
// its unit normal where its faces are one plane (|n| >= ONE_PLANE), else 0.
vec3 plane_normal(vec3 n) {
    return length(n) < ONE_PLANE ? vec3(0.0) : normalize(n);
}

// How much of a voxel whose plane_normal is u side j (axis s) sees lit: 1 where its faces are
// not one plane (u = 0); for a plane, 1 where s is in front of it or along it (u.s >= 0), 0
// where s is within 60 degrees of its back's normal -u (u.s <= -1/2), linear between. The
// directional volume of cones travelling along +a meets its voxels' sides toward -a.
float front_share(vec3 u, int j) {
    return clamp(1.0 + 2.0 * dot(u, side_axis(j)), 0.0, 1.0);
}

// Side j's normal in 21 bits from bit 21 j of the 128 of a uvec4: its component along the
// side's axis (in [0, 1], 7 bits as 1..127; 0 where the side has none) and the two across it
// (in [-1, 1], 7 bits each).
const int SIDE_BITS = 21;

uint side_bits(uvec4 v, int pos, int n) {
    int w = pos / 32, o = pos % 32;
    uint bits = v[w] >> o;
    if (o + n > 32) bits |= v[w + 1] << (32 - o);
    return bits & ((1u << n) - 1u);
}

void pack_side_normal(inout uvec4 v, vec3 m, int j) {
    int a = j / 2, pos = SIDE_BITS * j;
    float along = abs(m[a]);
    uint code = 1u + uint(round(clamp(along, 0.0, 1.0) * 126.0));
    code |= uint(round(clamp(m[(a + 1) % 3] * 0.5 + 0.5, 0.0, 1.0) * 127.0)) << 7;
    code |= uint(round(clamp(m[(a + 2) % 3] * 0.5 + 0.5, 0.0, 1.0) * 127.0)) << 14;
    int w = pos / 32, o = pos % 32;
    v[w] |= code << o;
    if (o + SIDE_BITS > 32) v[w + 1] |= code >> (32 - o);
}

// Side j's normal from the packed uvec4, or its axis where it has none.
vec3 side_normal(uvec4 v, int j) {
    uint code = side_bits(v, SIDE_BITS * j, SIDE_BITS);
    if ((code & 127u) == 0u) return side_axis(j);
    int a = j / 2;
    vec3 m;
    m[a] = ((j & 1) == 0 ? 1.0 : -1.0) * float((code & 127u) - 1u) / 126.0;
    m[(a + 1) % 3] = float((code >> 7) & 127u) / 127.0 * 2.0 - 1.0;
    m[(a + 2) % 3] = float((code >> 14) & 127u) / 127.0 * 2.0 - 1.0;
    return m;
}

// The albedo volume's fourth byte for a cover c in [0, 1] (1..255), and the cover an albedo
// word holds.
float cover_code(float c) {
    return max(round(clamp(c, 0.0, 1.0) * 255.0), 1.0);
}

float albedo_cover(uint albedo_word) {
    return float(albedo_word >> 24) / 255.0;
}


// Where the surface lies in its voxel: each sample's signed distance from the voxel's centre
// to its triangle's plane, along the sample's normal (voxel units, |d| <= sqrt(3)/2). The
// voxel keeps the largest, the outermost surface on the normals' side (an atomic maximum:
// order-independent like the sums), in the 8 bits of the normal volume that a count would
// fill (voxel_resolve.comp). The voxel light reads the shadow maps there, on the surface,
// rather than at the centre pushed off it by half a voxel, which sees past overhangs that
// shadow the surface: at grazing light, far past (voxel_light.comp). Not the mean: where a
// voxel holds several faces of a small object, their mean plane lies inside it, in its own
// shadow.
const float MAX_SURFACE_OFFSET = 0.8660254;

// The offset d as the word SUM_OFFSET keeps the maximum of: 1 + its 8-bit code (0: none).
uint surface_offset_word(float d) {
    return 1u + uint(round(clamp(d / MAX_SURFACE_OFFSET * 0.5 + 0.5, 0.0, 1.0) * 255.0));
}

float decode_surface_offset(float e) {
    return (e * 2.0 - 1.0) * MAX_SURFACE_OFFSET;
}

// A sample's channels in fixed point: what voxelize.frag adds to the sums.
uvec3 sum_sample(vec3 value, uint one) {
    return uvec3(round(clamp(value, 0.0, 1.0) * float(one)));
}

// A signed sample in [-1, 1] for the sides' sums (SUM_SIDES): halved, in fixed point, as the
// two's complement words an atomic add sums.
uvec4 signed_sum_sample(vec4 value, uint one) {
    return uvec4(ivec4(round(clamp(value, -1.0, 1.0) * 0.5 * float(one))));
}

// The mean of `count` samples whose fixed-point channels add up to `sum`, in [0,1].
vec3 sum_mean(uvec3 sum, uint count, uint one) {
    return vec3(sum) / (float(count) * float(one));
}

// Separating-axis test of a triangle (grid coordinates) against the axis-aligned box
// centre c, half size h. Touching counts as overlapping (conservative).
bool sat_axis_separates(vec3 axis, vec3 a, vec3 b, vec3 d, vec3 h) {
    float len2 = dot(axis, axis);
    if (len2 < 1e-20) return false;
    float p0 = dot(axis, a), p1 = dot(axis, b), p2 = dot(axis, d);
    float r = dot(h, abs(axis));
    float eps = 1e-5 * (r + 1e-3 * sqrt(len2));
    return min(p0, min(p1, p2)) > r + eps || max(p0, max(p1, p2)) < -r - eps;
}

bool triangle_box_overlap(vec3 c, vec3 h, vec3 t0, vec3 t1, vec3 t2) {
    vec3 a = t0 - c, b = t1 - c, d = t2 - c;
    vec3 e[3] = vec3[3](b - a, d - b, a - d);
    vec3 axes[3] = vec3[3](vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, 0, 1));
    for (int i = 0; i < 3; ++i) {
        if (sat_axis_separates(axes[i], a, b, d, h)) return false;
    }
    if (sat_axis_separates(cross(e[0], e[1]), a, b, d, h)) return false;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            if (sat_axis_separates(cross(e[i], axes[j]), a, b, d, h)) return false;
        }
    }
    return true;
}

// Dominant-axis projection: axis 0 (x) -> (y, z, x), 1 (y) -> (z, x, y), 2 (z) -> (x, y, z):
// (u, v) in the image plane, w along the projection axis.
vec3 to_uvw(vec3 p, uint axis) {
    return axis == 0u ? p.yzx : (axis == 1u ? p.zxy : p);
}

vec3 from_uvw(vec3 q, uint axis) {
    return axis == 0u ? q.zxy : (axis == 1u ? q.yzx : q);
}

#endif
