#version 460
#extension GL_EXT_control_flow_attributes : require
// Reference path tracer (the ground truth for the accuracy sweep). Unbiased for dvsgi's scene
// model: two-sided triangles, Lambert albedo/pi + energy-normalised Blinn-Phong (brdf.glsl),
// two-sided Lambertian emission, and directional/point/spot lights (lights.glsl) sampled by
// next-event estimation. Emissive surfaces are found by the paths themselves. The sky
// (sky.glsl) is what rays that leave the scene see; each surface also draws one direction from
// the sky's tables (luminance x sin theta, render::sky) and weighs it against the BRDF's own
// direction by multiple importance sampling (the power heuristic). Paths end by
// Russian roulette; `size.w` caps the number of indirect bounces (0 = direct light only).
// Each invocation traces `pc.samples` paths (the host sends 1 and dispatches again: see
// reference::TracePass) through one pixel (through its centre, as the
// rasterizer samples, or spread over it with `info.y`) and
// adds their radiance and squared radiance to two accumulators, so the host can form the
// mean and the variance of the mean.
#include "common.glsl"
#include "brdf.glsl"
#include "lights.glsl"
#include "scene.glsl"
#include "material.glsl"
#include "sky.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const uint TEXTURE_COUNT = 1;

// Mirrors reference::PtParams.
struct PtParams {
    mat4 inv_view_proj;
    vec4 camera;  // xyz unused (rays start on the near plane), w ray offset (scene units)
    uvec4 size;   // x width, y height, z light count, w max indirect bounces
    uvec4 info;   // x seed, y 1: jitter over the pixel (box filter), 0: through its centre,
                  // z triangle count, w 1: specular lobes at the first surface only
    vec4 sky;     // sky.glsl's parameters; w 1 when the sampling tables hold light
    uvec4 sky_size;  // x, y the sky map's width and height
};

struct BvhNode {
    vec4 lo;  // xyz min, w bits: first triangle (leaf) or left child (inner)
    vec4 hi;  // xyz max, w bits: triangle count (leaf) or 0 (inner)
};

struct Tri {
    vec4 v0;  // w bits: material index
    vec4 v1;
    vec4 v2;
};

struct TriShade {
    vec4 n0;
    vec4 n1;
    vec4 n2;
    vec4 uv01;
    vec4 uv2;
};

layout(set = 0, binding = 0) uniform ParamBlock { PtParams params; };
layout(set = 0, binding = 1, std430) readonly buffer Nodes { BvhNode nodes[]; };
layout(set = 0, binding = 2, std430) readonly buffer Tris { Tri tris[]; };
layout(set = 0, binding = 3, std430) readonly buffer Shades { TriShade shades[]; };
layout(set = 0, binding = 4, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 5, std430) readonly buffer Lights { Light lights[]; };
layout(set = 0, binding = 6) uniform texture2D textures[TEXTURE_COUNT];
layout(set = 0, binding = 9) uniform sampler texture_sampler;
layout(set = 0, binding = 7, rgba32f) uniform image2D accum;     // rgb sum, a accepted samples
layout(set = 0, binding = 8, rgba32f) uniform image2D accum_sq;  // rgb sum of squares, a rejected samples
// render::sky::SkySampling: the row CDF (h + 1), each row's texel CDF (h rows of w + 1), each
// texel's density per unit of image area (w h).
layout(set = 0, binding = 10, std430) readonly buffer SkyTables { float sky_table[]; };
layout(set = 0, binding = 11) uniform sampler2D sky_map;

layout(push_constant) uniform Push {
    uint first_sample;
    uint samples;
} pc;

const uint STACK_SIZE = 48u;  // reference::bvh::MAX_DEPTH
const float T_FAR = 3.0e38;

// PCG hash (Jarzynski and Olano 2020).
uint pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float rand(inout uint rng) {
    rng = pcg(rng);
    return float(rng >> 8) * (1.0 / 16777216.0);
}

// An orthonormal frame around unit n (Duff et al. 2017).
mat3 frame_of(vec3 n) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    vec3 bt = vec3(b, s + n.y * n.y * a, -n.y);
    return mat3(t, bt, n);
}

// Reciprocal that keeps the slab test free of 0 * inf.
vec3 safe_inverse(vec3 d) {
    return vec3(d.x != 0.0 ? 1.0 / d.x : 1e30, d.y != 0.0 ? 1.0 / d.y : 1e30, d.z != 0.0 ? 1.0 / d.z : 1e30);
}

float box_entry(BvhNode n, vec3 o, vec3 inv, float t_max) {
    vec3 a = (n.lo.xyz - o) * inv;
    vec3 b = (n.hi.xyz - o) * inv;
    vec3 mn = min(a, b);
    vec3 mx = max(a, b);
    float t0 = max(max(mn.x, mn.y), max(mn.z, 0.0));
    float t1 = min(min(mx.x, mx.y), min(mx.z, t_max));
    return t0 <= t1 ? t0 : -1.0;
}

#include "scene_texel.glsl"

vec2 hit_uv(TriShade sh, vec2 b) {
    return sh.uv01.xy * (1.0 - b.x - b.y) + sh.uv01.zw * b.x + sh.uv2.xy * b.y;
}

// Whether triangle `i` is there at barycentrics `b`: false where its material's alpha mask
// (level 0, the full-resolution truth) is under the cutoff.
bool opaque_at(uint i, vec2 b) {
    int mask = materials[floatBitsToUint(tris[i].v0.w)].texture.y;
    return mask < 0 || texel(mask, hit_uv(shades[i], b)).a >= MASK_CUTOFF;
}

struct Hit {
    float t;
    uint tri;
    vec2 uv;
};

// The watertight ray-triangle test (Woop, Benthin and Wald, JCGT 2013): the ray's frame puts
// its direction on the z axis (`WaterRay`), each vertex is sheared into it, and the three edge
// functions decide the hit. An edge shared by two triangles is evaluated from the same two
// sheared vertices in both, so a ray through it hits at least one of them (Möller–Trumbore
// does not promise that: on a GPU whose compiler fuses its products differently, a ray along
// the diagonal of a quad passed between its two triangles). `precise` keeps the compiler from
// fusing the products, which would break the symmetry. Both faces count.
struct WaterRay {
    ivec3 k;     // the axes kx, ky, kz (kz: the largest component of d)
    vec3 shear;  // (-d[kx] / d[kz], -d[ky] / d[kz], 1 / d[kz])
};

WaterRay water_ray(vec3 d) {
    vec3 a = abs(d);
    int kz = a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
    if (d[kz] < 0.0) {
        int tmp = kx;
        kx = ky;
        ky = tmp;
    }
    return WaterRay(ivec3(kx, ky, kz), vec3(-d[kx] / d[kz], -d[ky] / d[kz], 1.0 / d[kz]));
}

// Vertex v relative to the ray origin o, sheared: (x, y) in the plane across the ray, z along it.
vec3 shear_vertex(WaterRay r, vec3 o, vec3 v) {
    precise vec3 a = v - o;
    precise float x = a[r.k.x] + r.shear.x * a[r.k.z];
    precise float y = a[r.k.y] + r.shear.y * a[r.k.z];
    return vec3(x, y, r.shear.z * a[r.k.z]);
}

// The hit distance in t (0 < t < t_max) and the barycentrics of v1 and v2 in b.
bool hit_triangle(WaterRay r, vec3 o, Tri tri, float t_max, out float t, out vec2 b) {
    vec3 A = shear_vertex(r, o, tri.v0.xyz);
    vec3 B = shear_vertex(r, o, tri.v1.xyz);
    vec3 C = shear_vertex(r, o, tri.v2.xyz);
    precise float U = C.x * B.y - C.y * B.x;
    precise float V = A.x * C.y - A.y * C.x;
    precise float W = B.x * A.y - B.y * A.x;
    if ((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) return false;
    float det = U + V + W;
    if (det == 0.0) return false;
    float inv_det = 1.0 / det;
    t = (U * A.z + V * B.z + W * C.z) * inv_det;
    b = vec2(V, W) * inv_det;
    return t > 0.0 && t < t_max;
}

// Closest hit before t_max (or any hit, with `any_hit`).
bool trace(vec3 o, vec3 d, float t_max, bool any_hit, out Hit hit) {
    WaterRay wr = water_ray(d);
    hit.t = t_max;
    hit.tri = 0u;
    hit.uv = vec2(0.0);
    bool found = false;
    vec3 inv = safe_inverse(d);
    if (box_entry(nodes[0], o, inv, t_max) < 0.0) return false;
    uint stack_node[STACK_SIZE];
    float stack_t[STACK_SIZE];
    uint sp = 0u;
    uint node = 0u;
    for (;;) {
        BvhNode n = nodes[node];
        uint count = floatBitsToUint(n.hi.w);
        uint first = floatBitsToUint(n.lo.w);
        bool descend = false;
        // A leaf, or the empty root of a scene without triangles (no inner node points at 0).
        if (count > 0u || first == 0u) {
            for (uint i = first; i < first + count; ++i) {
                float t;
                vec2 b;
                if (hit_triangle(wr, o, tris[i], hit.t, t, b) && opaque_at(i, b)) {
                    hit.t = t;
                    hit.tri = i;
                    hit.uv = b;
                    found = true;
                    if (any_hit) return true;
                }
            }
        } else {
            float tl = box_entry(nodes[first], o, inv, hit.t);
            float tr = box_entry(nodes[first + 1u], o, inv, hit.t);
            if (tl >= 0.0 && tr >= 0.0) {
                bool left_near = tl <= tr;
                if (sp < STACK_SIZE) {
                    stack_node[sp] = left_near ? first + 1u : first;
                    stack_t[sp] = left_near ? tr : tl;
                    ++sp;
                }
                node = left_near ? first : first + 1u;
                descend = true;
            } else if (tl >= 0.0) {
                node = first;
                descend = true;
            } else if (tr >= 0.0) {
                node = first + 1u;
                descend = true;
            }
        }
        if (descend) continue;
        bool popped = false;
        while (sp > 0u) {
            --sp;
            if (stack_t[sp] <= hit.t) {
                node = stack_node[sp];
                popped = true;
                break;
            }
        }
        if (!popped) break;
    }
    return found;
}

struct Surface {
    vec3 P;
    vec3 ng;  // geometric normal, towards the incoming ray
    vec3 ns;  // shading normal, on the same side as ng
    vec3 albedo;
    vec3 ks;
    float shininess;
    vec3 emission;
};

// The shading normal n bent by the material's normal or height map (material.glsl: level 0, the
// same as the G-buffer's), in the triangle's own UV frame. A uniform loop over the textures, as
// texel() does.
vec3 bent_normal(Material m, Tri tri, TriShade sh, vec2 uv, vec3 n) {
    UvFrame f = uv_frame(tri.v1.xyz - tri.v0.xyz, tri.v2.xyz - tri.v0.xyz, sh.uv01.zw - sh.uv01.xy, sh.uv2.xy - sh.uv01.xy);
    vec3 p = n;
    [[dont_unroll]] for (uint i = 0u; i < TEXTURE_COUNT; ++i) {
        if (i == uint(m.texture.z)) p = mapped_normal(textures[i], texture_sampler, m.texture.w, n, f, uv, m.emission.a);
    }
    return p;
}

// The surface at a hit, with the same material rules as the G-buffer (gbuffer.frag).
Surface surface_at(Hit h, vec3 o, vec3 d) {
    Tri tri = tris[h.tri];
    TriShade sh = shades[h.tri];
    Surface s;
    float w = 1.0 - h.uv.x - h.uv.y;
    s.P = tri.v0.xyz * (1.0 - h.uv.x - h.uv.y) + tri.v1.xyz * h.uv.x + tri.v2.xyz * h.uv.y;
    vec3 ng = safe_normalize(cross(tri.v1.xyz - tri.v0.xyz, tri.v2.xyz - tri.v0.xyz), -d);
    if (dot(ng, d) > 0.0) ng = -ng;
    vec3 n = safe_normalize(sh.n0.xyz * w + sh.n1.xyz * h.uv.x + sh.n2.xyz * h.uv.y, ng);
    if (dot(n, ng) < 0.0) n = -n;
    s.ng = ng;
    s.ns = n;
    Material m = materials[floatBitsToUint(tri.v0.w)];
    vec2 uv = hit_uv(sh, h.uv);
    vec3 albedo = m.albedo.rgb;
    if (m.texture.x >= 0) albedo *= texel(m.texture.x, uv).rgb;
    if (m.texture.z >= 0 && m.texture.w != 0) s.ns = keep_facing(bent_normal(m, tri, sh, uv, n), n, ng);
    s.albedo = clamp(albedo, 0.0, 1.0);
    s.ks = clamp(m.specular.rgb, 0.0, 1.0);
    s.shininess = clamp(m.specular.a, 0.0, HALF_MAX);
    s.emission = min(max(m.emission.rgb, 0.0), vec3(HALF_MAX));
    return s;
}

// Density (per solid angle) of sampling `wi` from the Blinn-Phong half-vector distribution.
float specular_pdf(vec3 n, vec3 V, vec3 wi, float shininess) {
    vec3 h = safe_normalize(V + wi, n);
    float cos_h = max(dot(n, h), 0.0);
    float vdoth = dot(V, h);
    if (vdoth <= 0.0) return 0.0;
    return (shininess + 1.0) * INV_PI * 0.5 * pow(cos_h, shininess) / (4.0 * vdoth);
}

float mean3(vec3 c) {
    return (c.r + c.g + c.b) * (1.0 / 3.0);
}

// The sky map's texel along d: the nearest, as the sampling tables were made from texels.
ivec2 sky_texel(vec3 d) {
    ivec2 size = ivec2(params.sky_size.xy);
    return min(ivec2(sky_uv(d, params.sky.xy) * vec2(size)), size - 1);
}

vec3 sky_at(vec3 d) {
    return has_sky(params.sky) ? texelFetch(sky_map, sky_texel(d), 0).rgb : vec3(0.0);
}

bool sky_sampled() {
    return params.sky.w > 0.5;
}

// The density per solid angle of a texel of image density `density` at polar angle sin_theta.
float sky_solid_angle_pdf(float density, float sin_theta) {
    return sin_theta > 0.0 ? density / (2.0 * PI * PI * sin_theta) : 0.0;
}

float sky_density(uvec2 texel) {
    uint w = params.sky_size.x, h = params.sky_size.y;
    return sky_table[(h + 1u) + h * (w + 1u) + texel.y * w + texel.x];
}

// Density per solid angle of drawing d from the sky's tables.
float sky_pdf(vec3 d) {
    return sky_solid_angle_pdf(sky_density(uvec2(sky_texel(d))), sqrt(max(0.0, 1.0 - d.y * d.y)));
}

// The entry i of the n + 1 cumulative values from `base` with cdf[i] <= x < cdf[i + 1].
uint cdf_find(uint base, uint n, float x) {
    uint lo = 0u, hi = n;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (sky_table[base + mid] <= x) lo = mid;
        else hi = mid;
    }
    return lo;
}

// A direction drawn from the sky's tables (a row, then a texel in it, uniform within the
// texel) and its density per solid angle.
vec3 sample_sky(float u1, float u2, out float pdf) {
    uint w = params.sky_size.x, h = params.sky_size.y;
    uint row = cdf_find(0u, h, u1);
    float fv = (u1 - sky_table[row]) / max(sky_table[row + 1u] - sky_table[row], 1e-30);
    uint base = (h + 1u) + row * (w + 1u);
    uint col = cdf_find(base, w, u2);
    float fu = (u2 - sky_table[base + col]) / max(sky_table[base + col + 1u] - sky_table[base + col], 1e-30);
    vec2 uv = (vec2(col, row) + clamp(vec2(fu, fv), 0.0, 0.99999)) / vec2(w, h);
    pdf = sky_solid_angle_pdf(sky_density(uvec2(col, row)), sin(PI * uv.y));
    return sky_dir(uv, params.sky.xy);
}

// The power heuristic's weight of a strategy of density a against one of density b.
float mis_weight(float a, float b) {
    return a * a / max(a * a + b * b, 1e-30);
}

// Density (per solid angle) of the path's continuation drawing wi at surface s: the diffuse
// lobe or the specular one, the latter with probability p_spec.
float lobe_pdf(Surface s, vec3 V, vec3 wi, float p_spec) {
    float cos_i = dot(s.ns, wi);
    if (cos_i <= 0.0) return 0.0;
    return (1.0 - p_spec) * cos_i * INV_PI + p_spec * specular_pdf(s.ns, V, wi, s.shininess);
}

// One direction drawn from the sky towards surface s, shadowed: its contribution, weighed
// against the continuation's density where the path continues (`continues`).
vec3 sky_light(Surface s, vec3 V, vec3 origin, float p_spec, bool continues, inout uint rng) {
    float u1 = rand(rng), u2 = rand(rng);
    float pdf;
    vec3 wi = sample_sky(u1, u2, pdf);
    float cos_theta = dot(s.ns, wi);
    if (!(pdf > 0.0) || cos_theta <= 0.0 || dot(s.ng, wi) <= 0.0) return vec3(0.0);
    Hit blocker;
    if (trace(origin, wi, T_FAR, true, blocker)) return vec3(0.0);
    float w = continues ? mis_weight(pdf, lobe_pdf(s, V, wi, p_spec)) : 1.0;
    vec3 f = brdf_diffuse(s.albedo) + brdf_specular(s.ks, s.shininess, s.ns, V, wi);
    return f * sky_at(wi) * cos_theta * (w / pdf);
}

vec3 radiance(vec3 o, vec3 d, float t_max, inout uint rng) {
    vec3 L = vec3(0.0);
    vec3 beta = vec3(1.0);
    uint max_bounces = params.size.w;
    uint light_count = params.size.z;
    float eps0 = params.camera.w;
    // The density the last continuation drew d with (0: the camera's ray, which no other
    // strategy finds).
    float last_pdf = 0.0;
    for (uint depth = 0u; depth < 1024u; ++depth) {
        Hit h;
        if (!trace(o, d, t_max, false, h)) {
            // Left the scene: the sky, weighed against drawing d from the sky's tables.
            float w = last_pdf > 0.0 && sky_sampled() ? mis_weight(last_pdf, sky_pdf(d)) : 1.0;
            L += beta * sky_at(d) * w;
            break;
        }
        Surface s = surface_at(h, o, d);
        // `reference --specular first`: later surfaces are Lambertian (voxel cone tracing's
        // transport, without caustics or glossy interreflection).
        if (depth > 0u && params.info.w == 1u) s.ks = vec3(0.0);
        vec3 V = -d;
        L += beta * s.emission;
        float eps = eps0 + 1e-6 * max(abs(s.P.x), max(abs(s.P.y), abs(s.P.z)));
        vec3 origin = s.P + s.ng * eps;
        // Next-event estimation: every light once.
        for (uint i = 0u; i < light_count; ++i) {
            Light l = lights[i];
            LightSample ls = sample_light(l, s.P);
            float cos_theta = dot(s.ns, ls.wi);
            if (cos_theta <= 0.0 || dot(s.ng, ls.wi) <= 0.0) continue;
            if (max(ls.irradiance.r, max(ls.irradiance.g, ls.irradiance.b)) <= 0.0) continue;
            if (l.shadow.x >= 0) {
                float reach = ls.distance > 0.0 ? ls.distance * (1.0 - 1e-5) - 2.0 * eps : T_FAR;
                Hit blocker;
                if (reach > 0.0 && trace(origin, ls.wi, reach, true, blocker)) continue;
            }
            vec3 f = brdf_diffuse(s.albedo) + brdf_specular(s.ks, s.shininess, s.ns, V, ls.wi);
            L += beta * f * ls.irradiance * cos_theta;
        }
        // Continue the path: pick the diffuse or the specular lobe, evaluate the whole BRDF
        // over the mixture density (unbiased for any choice probability).
        float wd = mean3(s.albedo);
        float ws = mean3(s.ks);
        bool continues = depth < max_bounces && wd + ws > 0.0;
        float p_spec = wd + ws > 0.0 ? ws / (wd + ws) : 0.0;
        if (sky_sampled()) L += beta * sky_light(s, V, origin, p_spec, continues, rng);
        if (!continues) break;
        mat3 tbn = frame_of(s.ns);
        vec3 wi;
        float u1 = rand(rng), u2 = rand(rng);
        if (rand(rng) < p_spec) {
            float cos_h = pow(max(u1, 1e-30), 1.0 / (s.shininess + 1.0));
            float sin_h = sqrt(max(0.0, 1.0 - cos_h * cos_h));
            float phi = 2.0 * PI * u2;
            vec3 hv = tbn * vec3(sin_h * cos(phi), sin_h * sin(phi), cos_h);
            wi = 2.0 * dot(V, hv) * hv - V;
        } else {
            float r = sqrt(u1);
            float phi = 2.0 * PI * u2;
            wi = tbn * vec3(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u1)));
        }
        float cos_i = dot(s.ns, wi);
        if (cos_i <= 0.0 || dot(s.ng, wi) <= 0.0) break;
        float pdf = lobe_pdf(s, V, wi, p_spec);
        if (!(pdf > 0.0)) break;
        last_pdf = pdf;
        vec3 f = brdf_diffuse(s.albedo) + brdf_specular(s.ks, s.shininess, s.ns, V, wi);
        beta *= f * cos_i / pdf;
        if (depth >= 2u) {
            float q = min(max(beta.r, max(beta.g, beta.b)), 0.95);
            if (!(rand(rng) < q)) break;
            beta /= q;
        }
        o = origin;
        d = normalize(wi);
        t_max = T_FAR;
    }
    return L;
}

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    uvec2 size = params.size.xy;
    if (any(greaterThanEqual(px, size))) return;
    vec3 sum = vec3(0.0), sum_sq = vec3(0.0);
    float accepted = 0.0, rejected = 0.0;
    for (uint k = 0u; k < pc.samples; ++k) {
        uint sample_index = pc.first_sample + k;
        uint rng = pcg(params.info.x ^ pcg(px.x + pcg(px.y + pcg(sample_index))));
        vec2 jitter = vec2(rand(rng), rand(rng));
        if (params.info.y == 0u) jitter = vec2(0.5);
        vec2 ndc = (vec2(px) + jitter) / vec2(size) * 2.0 - 1.0;
        // From the near plane to the far plane: the rasterizer's visible range.
        vec4 near_h = params.inv_view_proj * vec4(ndc, 0.0, 1.0);
        vec4 far_h = params.inv_view_proj * vec4(ndc, 1.0, 1.0);
        vec3 o = near_h.xyz / near_h.w;
        vec3 span = far_h.xyz / far_h.w - o;
        float len = length(span);
        vec3 L = radiance(o, span / len, len, rng);
        if (any(isnan(L)) || any(isinf(L))) {
            rejected += 1.0;
            continue;
        }
        sum += L;
        sum_sq += L * L;
        accepted += 1.0;
    }
    ivec2 p = ivec2(px);
    vec4 a = pc.first_sample == 0u ? vec4(0.0) : imageLoad(accum, p);
    vec4 b = pc.first_sample == 0u ? vec4(0.0) : imageLoad(accum_sq, p);
    imageStore(accum, p, a + vec4(sum, accepted));
    imageStore(accum_sq, p, b + vec4(sum_sq, rejected));
}
