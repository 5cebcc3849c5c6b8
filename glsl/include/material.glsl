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
// Mirror render::scene_gpu::{NORMAL_MAP, HEIGHT_MAP} (and HEIGHT_MAP_UNITS below).
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

// Tangent-space normals as the GPU stores them (scene::maps::encode_unit): (x + 1) / 2,
// (y + 1) / 2, 1 - z. Height maps are uploaded as the normal maps of their material's relief.
// A filtered texel is the mean of the unit normals it covers, shorter than 1 where they
// disagree; a stored unit normal (z >= 0.5) decodes within STORED_NORMAL_ERROR of length 1.
const float STORED_NORMAL_ERROR = 0.013;  // mirrors scene::maps::STORED_NORMAL_ERROR
const int HEIGHT_MAP_UNITS = 3;           // mirrors render::scene_gpu::HEIGHT_MAP_UNITS

vec3 decode_tangent(vec4 texel) {
    return vec3(texel.xy * 2.0 - 1.0, 1.0 - texel.z);
}

// A map is uploaded as the normal map of its material's relief (render::relief), so a normal
// map's and a texture-space relief's (HEIGHT_MAP) tangent vector is used as it is. A relief in
// scene units (HEIGHT_MAP_UNITS) was made for the material's mean scene units per unit of UV
// (`factor`, GpuMaterial::emission.a): its slopes scale by that over the surface's own. The
// length (the normals' agreement) is kept: exact for a unit vector (a point, level 0), an
// approximation of the scaled normals' mean where the ratio is not 1.
vec3 scale_relief(vec3 tn, int kind, UvFrame f, float factor) {
    if (kind != HEIGHT_MAP_UNITS || !f.ok) return tn;
    float k = factor / sqrt(max(length(cross(f.du, f.dv)), 1e-30));
    vec3 p = vec3(tn.xy * k, tn.z);
    float l = length(p);
    return l > 1e-30 ? p * (length(tn) / l) : tn;
}

// Tangent-space vector tn (OpenGL convention: +x along +u, +y along the OBJ's +v, which is -v
// of dvsgi's top-down UVs) in the frame of the shading normal n: unnormalized, as long as tn.
// On a surface with conformal UVs this is the bump-mapped normal of the height field exactly
// (scene::maps::normals_from_heights); mirrored UVs flip the bitangent.
vec3 tangent_to_world(vec3 n, UvFrame f, vec3 tn) {
    vec3 t = f.du - n * dot(n, f.du);
    if (!f.ok || dot(t, t) < 1e-30) return n * length(tn);
    t = normalize(t);
    vec3 b = cross(n, t);
    if (dot(b, -f.dv) < 0.0) b = -b;  // mirrored UVs
    return tn.x * t + tn.y * b + tn.z * n;
}

// The maps that bend normals are read two ways, by one convention:
// - at a point (the path tracer, the truth): level 0, bilinear, the filter written out (texel
//   fetches: the same arithmetic in every stage, whatever the sampler's anisotropy), the
//   normal normalized: `mapped_normal`;
// - over a footprint (the G-buffer at a pixel, the voxelizer at a voxel): the mip chain's
//   mean normal, filtered by the sampler at the footprint's gradients, not normalized:
//   `filtered_normal`. For Lambertian light, max(0, mean . l) is the footprint's mean of
//   max(0, n . l) wherever no normal under it faces away from the light, so a minified bumpy
//   wall shows the average a supersampled or path-traced pixel converges to, not one
//   micro-normal out of many (salt-and-pepper noise, issue 42). The specular lobe widens by
//   the mean's shortness (Toksvig, `toksvig_shininess`).

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

// The shading normal n bent by map t (sampler s) of kind `kind` at the point uv, in the
// surface's UV frame f; `factor` as `scale_relief` takes it. Unit length.
vec3 mapped_normal(texture2D t, sampler s, int kind, vec3 n, UvFrame f, vec2 uv, float factor) {
    vec3 p = tangent_to_world(n, f, scale_relief(decode_tangent(bilinear_level0(t, s, uv)), kind, f, factor));
    return dot(p, p) > 1e-30 ? normalize(p) : n;
}

// The mean of t over the footprint spanned by the gradients dx, dy around uv: 4 x 4 taps at
// the centres of its sixteenths, each filtered over one. One trilinear tap over the whole
// footprint blurs over about two footprints (the mip texel's box and the bilinear tent): 7-9%
// off a jittered pixel's average on a bump field of 6 pixels a period, 2 x 2 taps still 5.7%
// on the stone wall of tests/maps.rs, 4 x 4 under 4% (the footprint's box blurred by a tent of
// a quarter of it). Only bump-mapped surfaces pay the 16 fetches.
vec4 footprint_mean(texture2D t, sampler s, vec2 uv, vec2 dx, vec2 dy) {
    vec2 hx = 0.25 * dx, hy = 0.25 * dy;
    vec4 sum = vec4(0.0);
    for (int i = 0; i < 16; ++i) {
        vec2 o = (float(i & 3) - 1.5) * hx + (float(i >> 2) - 1.5) * hy;
        sum += textureGrad(sampler2D(t, s), uv + o, hx, hy);
    }
    return sum / 16.0;
}

// The mean of the bent normals over the footprint of gradients (duvdx, duvdy) at uv: not
// normalized (length 1 where they agree, shorter where they do not).
vec3 filtered_normal(texture2D t, sampler s, int kind, vec3 n, UvFrame f, vec2 uv, vec2 duvdx, vec2 duvdy,
                     float factor) {
    vec4 texel = footprint_mean(t, s, uv, duvdx, duvdy);
    return tangent_to_world(n, f, scale_relief(decode_tangent(texel), kind, f, factor));
}

// Blinn-Phong exponent s over a footprint whose mean normal has length `len` (Toksvig 2005:
// s len / (len + s (1 - len))): the lobe widens by the spread of the normals under it. A
// shortness within STORED_NORMAL_ERROR is the storage's, not a spread.
float toksvig_shininess(float s, float len) {
    if (s <= 0.0) return s;
    float l = clamp(len / (1.0 - STORED_NORMAL_ERROR), 0.0, 1.0);
    return s * l / (l + s * (1.0 - l));
}

// A perturbed normal that turned away from the side the surface is seen from (ng) falls back
// to the unperturbed one.
vec3 keep_facing(vec3 perturbed, vec3 n, vec3 ng) {
    return dot(perturbed, ng) > 0.0 ? perturbed : n;
}

#endif
