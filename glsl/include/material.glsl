// Texture maps of a material (Material.texture in scene.glsl: x albedo, y alpha mask, z normal
// or height map, w what z is), shared by the G-buffer, the shadow maps, the voxelizer and the
// path tracer, so that every one of them cuts, and bends normals, the same way. Each caller
// samples its textures itself (implicit, explicit-gradient or level-0 lookups); these are the
// rules that turn the samples into a decision or a normal.
#ifndef DVSGI_MATERIAL_GLSL
#define DVSGI_MATERIAL_GLSL

// Scene textures are sampled images with one sampler (the sampler limit is 32 on lavapipe):
// a shader declares `textures[]` and, as its last binding, `texture_sampler`.
#define SCENE_TEXTURE(i) sampler2D(textures[i], texture_sampler)

// Mirrors scene::MASK_CUTOFF: a masked surface exists where the coverage is at least this.
const float MASK_CUTOFF = 0.5;
// Mirror render::scene_gpu::{NORMAL_MAP, HEIGHT_MAP}.
const int NORMAL_MAP = 1;
const int HEIGHT_MAP = 2;

// dP/du and dP/dv of a triangle (or of a pixel's footprint) from two position differences and
// the matching UV differences. `ok` is false where the UVs are degenerate.
struct UvFrame {
    vec3 du;
    vec3 dv;
    bool ok;
};

UvFrame uv_frame(vec3 dp1, vec3 dp2, vec2 duv1, vec2 duv2) {
    UvFrame f;
    float det = duv1.x * duv2.y - duv1.y * duv2.x;
    f.ok = abs(det) > 1e-20;
    float inv = f.ok ? 1.0 / det : 0.0;
    f.du = (dp1 * duv2.y - dp2 * duv1.y) * inv;
    f.dv = (dp2 * duv1.x - dp1 * duv2.x) * inv;
    f.ok = f.ok && all(lessThan(abs(f.du), vec3(3.0e38))) && all(lessThan(abs(f.dv), vec3(3.0e38)));
    return f;
}

// A tangent-space normal-map texel (OpenGL convention: +x along +u, +y along the OBJ's +v,
// which is -v of dvsgi's top-down UVs) applied to the shading normal n.
vec3 normal_from_map(vec3 n, UvFrame f, vec3 texel) {
    vec3 tn = texel * 2.0 - 1.0;
    vec3 t = f.du - n * dot(n, f.du);
    if (!f.ok || dot(t, t) < 1e-30) return n;
    t = normalize(t);
    vec3 b = cross(n, t);
    if (dot(b, -f.dv) < 0.0) b = -b;  // mirrored UVs
    vec3 p = tn.x * t + tn.y * b + tn.z * n;
    return dot(p, p) > 1e-30 ? normalize(p) : n;
}

// A height map's gradient dh = (dh/du, dh/dv) (per unit of UV) applied to the shading normal n:
// the surface displaced by scale * h along n (pbrt's bump mapping), with n standing in for
// the geometric normal: n' ~ n |du x dv| + sign (scale dh.v (du x n) + scale dh.u (n x dv)).
vec3 normal_from_height(vec3 n, UvFrame f, vec2 dh, float scale) {
    vec3 c = cross(f.du, f.dv);
    float area = length(c);
    if (!f.ok || area < 1e-30) return n;
    float s = dot(c, n) < 0.0 ? -1.0 : 1.0;
    vec3 p = n * area + s * scale * (dh.y * cross(f.du, n) + dh.x * cross(n, f.dv));
    return dot(p, p) > 1e-30 ? normalize(p) : n;
}

// The maps that bend normals are read at level 0, bilinear, by every renderer alike, with the
// filter written out (texel fetches: the same arithmetic in the fragment and compute stages,
// whatever the sampler's anisotropy or the device's filtering precision). The bump is a
// property of the surface point, as the map defines it at full resolution, not of the pixel or
// the sample that looks at it: a height map differenced at the level a footprint selects has its
// bumps flattened as pixels grow, so its strength followed the sampling density. Antialiasing
// comes from averaging point values: supersampling in the rasterizer, jitter in the path tracer.

// Texel i of level 0, wrapped (REPEAT) for i in -size..2 size - 1.
vec4 fetch_repeat(texture2D t, sampler s, ivec2 size, ivec2 i) {
    i += size * ivec2(lessThan(i, ivec2(0))) - size * ivec2(greaterThanEqual(i, size));
    return texelFetch(sampler2D(t, s), i, 0);
}

// Level 0 of t at uv, bilinear with repeat (texel centres at (i + 0.5) / size).
vec4 bilinear_level0(texture2D t, sampler s, vec2 uv) {
    ivec2 size = textureSize(sampler2D(t, s), 0);
    vec2 p = fract(uv) * vec2(size) - 0.5;
    vec2 corner = floor(p);
    vec2 f = p - corner;
    ivec2 i = ivec2(corner);
    vec4 below = mix(fetch_repeat(t, s, size, i), fetch_repeat(t, s, size, i + ivec2(1, 0)), f.x);
    vec4 above = mix(fetch_repeat(t, s, size, i + ivec2(0, 1)), fetch_repeat(t, s, size, i + ivec2(1, 1)), f.x);
    return mix(below, above, f.y);
}

// A height map's gradient (dh/du, dh/dv) per unit of UV at uv: central differences one texel
// apart on level 0 (heights in alpha: render::scene_gpu::upload_texture).
vec2 height_gradient(texture2D t, sampler s, vec2 uv) {
    vec2 d = 1.0 / vec2(textureSize(sampler2D(t, s), 0));
    float hu = bilinear_level0(t, s, uv + vec2(d.x, 0.0)).a - bilinear_level0(t, s, uv - vec2(d.x, 0.0)).a;
    float hv = bilinear_level0(t, s, uv + vec2(0.0, d.y)).a - bilinear_level0(t, s, uv - vec2(0.0, d.y)).a;
    return vec2(hu, hv) / (2.0 * d);
}

// The shading normal n bent by map t (sampler s) of kind `kind` (NORMAL_MAP or HEIGHT_MAP) at uv, in the
// surface's UV frame f; `scale` is a height map's displacement in scene units per unit height.
vec3 mapped_normal(texture2D t, sampler s, int kind, vec3 n, UvFrame f, vec2 uv, float scale) {
    if (kind == NORMAL_MAP) return normal_from_map(n, f, bilinear_level0(t, s, uv).rgb);
    return normal_from_height(n, f, height_gradient(t, s, uv), scale);
}

// A perturbed normal that turned away from the side the surface is seen from (ng) falls back
// to the unperturbed one.
vec3 keep_facing(vec3 perturbed, vec3 n, vec3 ng) {
    return dot(perturbed, ng) > 0.0 ? perturbed : n;
}

#endif
