#version 460
// Voxelization: each fragment is one voxel column along the dominant axis. Every voxel of the
// column within the triangle's depth range over the pixel square is tested exactly against
// the triangle (separating axes) and, if touched, receives a sample of linear albedo, normal
// and emission, added to its sums (voxel.glsl: integer atomics, so the result does not depend
// on the order fragments arrive in); voxel_resolve.comp turns the sums into averages. In the
// dynamic pass the invocation that gives a voxel its first sample appends the voxel to the
// work list (the static list is built in grid order by voxel_resolve.comp). Textures and
// normals are sampled over the part of the pixel's square that the triangle covers: at its
// centroid, with the texture-coordinate gradient over its extent, so at the mip level of that
// footprint (a normal or height map gives the mean of its normals there). (Interpolated attributes would not do: a conservative fragment's centre can lie
// past the triangle's edge, where they extrapolate, and a repeating texture wraps; geometry-
// shader dilation would stretch them.) Every rasterizer, with or without hardware conservative
// rasterization, so samples the same texels, and an alpha-masked surface voxelizes only where
// its coverage over the footprint it covers reaches the cutoff (the mask's mips keep the
// coverage, render::texture).
// With bricked volumes the same shader first runs with MARK set: it writes nothing but marks
// every brick the voxels it touches need (bricks.glsl), for the allocation that follows.
#include "common.glsl"
#include "scene.glsl"
#include "material.glsl"
#include "voxel.glsl"
#define VOXEL_LIST_BINDING 6
#define VOXEL_LIST_APPEND_ONLY
#include "voxel_list.glsl"

layout(constant_id = 0) const uint TEXTURE_COUNT = 1;
layout(constant_id = 2) const bool HAS_EMISSION = false;
layout(constant_id = 3) const bool HAS_FLAGS = false;
layout(constant_id = 4) const bool MARK = false;
// gi.attenuation = "per-side": the normals seen from each side (voxel.glsl, SUM_SIDES).
layout(constant_id = 5) const bool SIDE_NORMALS = false;

layout(set = 0, binding = 2, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 3) uniform texture2D textures[TEXTURE_COUNT];
layout(set = 0, binding = 7) uniform sampler texture_sampler;
layout(set = 0, binding = 4) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 5, r8ui) uniform uimage3D vox_flags;
layout(set = 0, binding = 8, r32ui) uniform uimage3D brick_maps[4];
// The sums (voxel.glsl), SUM_WORDS volumes; the emission's are placeholders without emission.
layout(set = 0, binding = 9, r32ui) uniform uimage3D vox_sums[SUM_WORDS];
#define BRICK_MAPS_WRITABLE
#include "bricks.glsl"

layout(push_constant) uniform Push { uint mark_static; } pc;

layout(location = 0) flat in vec3 g_normals[3];
layout(location = 3) flat in vec2 g_uvs[3];
layout(location = 6) flat in uint g_material;
layout(location = 7) flat in uint g_axis;
layout(location = 8) flat in vec3 g_t0;
layout(location = 9) flat in vec3 g_t1;
layout(location = 10) flat in vec3 g_t2;

// Add a sample's three channels to the sums from word `first` on.
void add_sample(ivec3 t, int first, vec3 value) {
    uvec3 q = sum_sample(value, grid.dims.w);
    if (q.x != 0u) imageAtomicAdd(vox_sums[first], t, q.x);
    if (q.y != 0u) imageAtomicAdd(vox_sums[first + 1], t, q.y);
    if (q.z != 0u) imageAtomicAdd(vox_sums[first + 2], t, q.z);
}

// A sample's normal n seen from each side it faces: (w n, w), w = n.s, into that side's sums
// (voxel.glsl, SUM_SIDES).
void add_side_normals(ivec3 t, vec3 n) {
    for (int a = 0; a < 3; ++a) {
        if (n[a] == 0.0) continue;
        int first = SUM_SIDES + 4 * (2 * a + (n[a] > 0.0 ? 0 : 1));
        float w = abs(n[a]);
        uvec4 q = signed_sum_sample(vec4(w * n, w), grid.dims.w);
        for (int i = 0; i < 4; ++i) {
            if (q[i] != 0u) imageAtomicAdd(vox_sums[first + i], t, q[i]);
        }
    }
}

// The bricks voxel vc needs: in the full-resolution pool and on each pooled directional level,
// the brick of the texel over it and the brick whose apron holds that texel.
void mark_bricks(ivec3 vc) {
    for (int p = 0; p <= int(grid.dims.y); ++p) {
        ivec3 t = vc >> p;
        ivec3 lo = t >> 3, hi = (t + 1) >> 3;
        for (int z = lo.z; z <= hi.z; ++z) {
            for (int y = lo.y; y <= hi.y; ++y) {
                for (int x = lo.x; x <= hi.x; ++x) brick_mark(p, ivec3(x, y, z));
            }
        }
    }
}

void list_append(ivec3 c) {
    uint i = atomicAdd(vlist.occupied.count, 1u);
    if (i < uint(vlist.entries.length())) {
        vlist.entries[i] = pack_voxel(c);
    } else {
        atomicAdd(vlist.dropped, 1u);
    }
}

float cross2(vec2 a, vec2 b) {
    return a.x * b.y - a.y * b.x;
}

// A convex polygon in raster coordinates: the pixel square (4 corners) clipped by a
// triangle's three edges has at most 7, and by a voxel slab's two lines at most 9.
struct Polygon {
    vec2 p[10];
    int count;
};

// The part of `poly` where a linear function of position is >= 0, given its value d[i] at
// each corner (Sutherland-Hodgman against one line).
void clip_polygon(inout Polygon poly, float d[10]) {
    Polygon kept;
    kept.count = 0;
    for (int i = 0; i < poly.count; ++i) {
        int j = (i + 1) % poly.count;
        if (d[i] >= 0.0) kept.p[kept.count++] = poly.p[i];
        if ((d[i] >= 0.0) != (d[j] >= 0.0)) kept.p[kept.count++] = mix(poly.p[i], poly.p[j], d[i] / (d[i] - d[j]));
    }
    poly = kept;
}

// The part of the pixel square at px that the triangle (a, b, c: raster coordinates) covers:
// the square clipped by the triangle's three edges.
struct Footprint {
    vec2 middle;
    vec2 extent;   // of its bounding box, at most one pixel on each axis
    bool empty;
    Polygon poly;  // its corners
    float area;    // in pixels: the share of the pixel square the triangle covers
};

Footprint clipped_pixel(vec2 px, vec2 a, vec2 b, vec2 c) {
    Polygon poly;
    poly.p[0] = px;
    poly.p[1] = px + vec2(1.0, 0.0);
    poly.p[2] = px + vec2(1.0);
    poly.p[3] = px + vec2(0.0, 1.0);
    poly.count = 4;
    vec2 tri[3] = vec2[3](a, b, c);
    float orient = cross2(b - a, c - a) >= 0.0 ? 1.0 : -1.0;
    for (int e = 0; e < 3; ++e) {
        vec2 p0 = tri[e], edge = tri[(e + 1) % 3] - p0;
        float d[10];
        for (int i = 0; i < poly.count; ++i) d[i] = orient * cross2(edge, poly.p[i] - p0);
        clip_polygon(poly, d);
    }
    Footprint f;
    f.empty = poly.count == 0;
    vec2 lo = vec2(1e30), hi = vec2(-1e30), mean = vec2(0.0), moment = vec2(0.0);
    float area2 = 0.0;
    for (int i = 0; i < poly.count; ++i) {
        vec2 s = poly.p[i] - px, t = poly.p[(i + 1) % poly.count] - px;
        float w = cross2(s, t);
        area2 += w;
        moment += (s + t) * w;
        mean += s;
        lo = min(lo, s);
        hi = max(hi, s);
    }
    // A sliver with no area (the triangle only grazes the square): its corners' mean.
    f.middle = px + (abs(area2) > 1e-6 ? moment / (3.0 * area2) : mean / float(max(poly.count, 1)));
    f.extent = max(hi - lo, vec2(0.0));
    f.poly = poly;
    f.area = min(abs(area2) * 0.5, 1.0);
    return f;
}

// The triangle's depth w at raster position q: its plane through a with normal n (uvw).
float plane_depth(vec2 q, vec3 a, vec3 n) {
    return a.z - (n.x * (q.x - a.x) + n.y * (q.y - a.y)) / n.z;
}

// The area (pixels) of the footprint's part whose depth lies in the voxel slab [k, k + 1] of
// the column (gi.voxel_cover = "area", voxel.glsl): the footprint clipped by the two lines
// where the triangle's plane crosses the slab's faces.
float slab_area(Footprint f, vec3 a, vec3 n, float k) {
    Polygon poly = f.poly;
    float d[10];
    for (int i = 0; i < poly.count; ++i) d[i] = plane_depth(poly.p[i], a, n) - k;
    clip_polygon(poly, d);
    for (int i = 0; i < poly.count; ++i) d[i] = k + 1.0 - plane_depth(poly.p[i], a, n);
    clip_polygon(poly, d);
    float area2 = 0.0;
    for (int i = 0; i < poly.count; ++i) area2 += cross2(poly.p[i], poly.p[(i + 1) % poly.count]);
    return min(abs(area2) * 0.5, 1.0);
}

// What the fragment samples of its triangle: the texture coordinates, their gradient along
// the raster's two axes over the covered footprint, and the interpolated normal.
struct SurfacePoint {
    vec2 uv;
    vec2 duv_dx;
    vec2 duv_dy;
    vec3 normal;
};

// The triangle (a, b, c: raster coordinates) over the part of pixel px it covers.
SurfacePoint surface_point(Footprint f, vec3 a, vec3 b, vec3 c) {
    vec2 e1 = b.xy - a.xy, e2 = c.xy - a.xy, q = f.middle - a.xy;
    float det = cross2(e1, e2);
    // Weights 1 and 2 are affine in the raster position, with gradients (e2.y, -e2.x) / det
    // and (-e1.y, e1.x) / det.
    vec3 w;
    w.y = cross2(q, e2) / det;
    w.z = cross2(e1, q) / det;
    w.x = 1.0 - w.y - w.z;
    vec2 du1 = g_uvs[1] - g_uvs[0], du2 = g_uvs[2] - g_uvs[0];
    SurfacePoint s;
    s.uv = w.x * g_uvs[0] + w.y * g_uvs[1] + w.z * g_uvs[2];
    s.duv_dx = f.extent.x * (du1 * e2.y - du2 * e1.y) / det;
    s.duv_dy = f.extent.y * (du2 * e1.x - du1 * e2.x) / det;
    s.normal = w.x * g_normals[0] + w.y * g_normals[1] + w.z * g_normals[2];
    return s;
}

void main() {
    int res = int(grid.dims.x);
    ivec2 px = ivec2(floor(gl_FragCoord.xy));
    vec3 a = to_uvw(g_t0, g_axis), b = to_uvw(g_t1, g_axis), c = to_uvw(g_t2, g_axis);
    vec3 n = cross(b - a, c - a);
    if (abs(n.z) < 1e-20) return;

    Footprint covered = clipped_pixel(vec2(px), a.xy, b.xy, c.xy);
    if (covered.empty) return;
    SurfacePoint sp = surface_point(covered, a, b, c);
    Material m = materials[g_material];
    vec3 albedo = m.albedo.rgb;
    int tex = m.texture.x;
    if (tex >= 0 && uint(tex) < TEXTURE_COUNT) {
        albedo *= textureGrad(SCENE_TEXTURE(tex), sp.uv, sp.duv_dx, sp.duv_dy).rgb;
    }
    int mask = m.texture.y;
    float coverage = 1.0;
    if (mask >= 0 && uint(mask) < TEXTURE_COUNT) {
        coverage = textureGrad(SCENE_TEXTURE(mask), sp.uv, sp.duv_dx, sp.duv_dy).a;
    }
    if (coverage < MASK_CUTOFF) return;
    // Depth w of the triangle's plane over the pixel square's corners, clamped to the triangle.
    float wmin = 1e30, wmax = -1e30;
    for (int i = 0; i < 4; ++i) {
        vec2 uv = vec2(px) + vec2(i & 1, i >> 1);
        float w = a.z - (n.x * (uv.x - a.x) + n.y * (uv.y - a.y)) / n.z;
        wmin = min(wmin, w);
        wmax = max(wmax, w);
    }
    wmin = max(wmin, min(a.z, min(b.z, c.z)));
    wmax = min(wmax, max(a.z, max(b.z, c.z)));
    int k0 = max(int(floor(wmin)), 0);
    int k1 = min(int(floor(wmax)), res - 1);
    if (px.x < 0 || px.y < 0 || px.x >= res || px.y >= res) return;

    vec3 face = safe_normalize(cross(g_t1 - g_t0, g_t2 - g_t0), vec3(0.0, 1.0, 0.0));
    vec3 nrm = safe_normalize(sp.normal, face);
    int bump = m.texture.z;
    if (bump >= 0 && uint(bump) < TEXTURE_COUNT && m.texture.w != 0) {
        // The bent normals' mean over the voxel's footprint (material.glsl), as the G-buffer
        // takes it over a pixel's; the voxel's normal is the mean of its samples.
        float size = grid.origin.w;
        UvFrame f = uv_frame((g_t1 - g_t0) * size, (g_t2 - g_t0) * size, g_uvs[1] - g_uvs[0], g_uvs[2] - g_uvs[0]);
        vec3 mean = filtered_normal(textures[bump], texture_sampler, m.texture.w, nrm, f, sp.uv, sp.duv_dx,
                                    sp.duv_dy, m.emission.a);
        nrm = keep_facing(mean, nrm, nrm);
    }
    vec3 emission = m.emission.rgb / grid.params.x;
    // The triangle's plane normal on the side of the sample's normal (voxel.glsl, SUM_OFFSET).
    vec3 facing = dot(face, nrm) < 0.0 ? -face : face;

    // A plane with slope <= 1 along u and v spans at most 3 voxels of the column.
    int k_last = min(k1, k0 + 3);
    // gi.voxel_cover = "area": each voxel's share of the footprint; the largest takes it all.
    float share[4] = float[4](0.0, 0.0, 0.0, 0.0);
    int widest = k0;
    if (AREA_COVER && !MARK) {
        for (int k = k0; k <= k_last; ++k) {
            share[k - k0] = slab_area(covered, a, n, float(k));
            if (share[k - k0] > share[widest - k0]) widest = k;
        }
        share[widest - k0] = covered.area;
    }
    for (int k = k0; k <= k_last; ++k) {
        vec3 voxel = from_uvw(vec3(px, k), g_axis);
        if (!triangle_box_overlap(voxel + 0.5, vec3(0.5), g_t0, g_t1, g_t2)) continue;
        ivec3 vc = ivec3(voxel);
        if (MARK) {
            mark_bricks(vc);
            continue;
        }
        ivec3 vt = full_texel(vc);  // resident: the mark pass marked its brick
        if (vt.x < 0) continue;
        // Dynamic geometry leaves static voxels alone: the dynamic clear keeps them, so every
        // update would average its samples in again and the static voxel would drift toward
        // the dynamic object's albedo and normal until its sample count saturates.
        if (HAS_FLAGS && pc.mark_static == 0u && imageLoad(vox_flags, vt).r != 0u) continue;
        uint earlier = imageAtomicAdd(vox_sums[SUM_COUNT], vt, 1u);
        if (earlier == 0u && pc.mark_static == 0u) list_append(vc);
        add_sample(vt, SUM_ALBEDO, albedo);
        add_sample(vt, SUM_NORMAL, nrm * 0.5 + 0.5);
        if (SIDE_NORMALS) add_side_normals(vt, nrm);
        imageAtomicMax(vox_sums[SUM_OFFSET], vt, surface_offset_word(dot(g_t0 - (voxel + 0.5), facing)));
        if (AREA_COVER) {
            uint cover = uint(round(clamp(share[k - k0], 0.0, 1.0) * float(grid.dims.w)));
            if (cover != 0u) imageAtomicAdd(vox_sums[SUM_COVER], vt, cover);
        }
        // Zeros count too (in the count): a half-emissive voxel emits half.
        if (HAS_EMISSION) add_sample(vt, SUM_EMISSION, emission);
        if (HAS_FLAGS && pc.mark_static != 0u) {
            imageStore(vox_flags, vt, uvec4(1u));
        }
    }
}
