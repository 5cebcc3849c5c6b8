// Rays through the scene's triangles with ray queries (GL_EXT_ray_query): the closest hit, with
// alpha masks cutting surfaces where their coverage is under the cutoff, a shadow-ray test,
// and the surface at a hit. The including shader enables GL_EXT_ray_query and declares,
// before including this file:
//   uniform accelerationStructureEXT scene_tlas;   (one instance per draw, custom index = draw)
//   buffer { float vertex_data[]; };               (render::scene_gpu::Vertex: 8 floats each)
//   buffer { uint index_data[]; };
//   buffer { RtDraw rt_draws[]; };                 (render::rays::RtDraw)
//   buffer { Instance instances[]; };  buffer { Material materials[]; };
//   the scene textures with an explicit-level sampler (scene_texel.glsl).
#ifndef DVSGI_RAY_QUERY_GLSL
#define DVSGI_RAY_QUERY_GLSL
#include "common.glsl"
#include "scene.glsl"
#include "scene_texel.glsl"

struct RayHit {
    float t;
    uint draw;
    uint prim;
    vec2 bary;  // of vertices 1 and 2
};

// Vertex indices of triangle `prim` of draw `draw`.
uvec3 triangle_vertices(uint draw, uint prim) {
    RtDraw d = rt_draws[draw];
    uint base = d.first_index + 3u * prim;
    return uvec3(index_data[base], index_data[base + 1u], index_data[base + 2u]) + uint(d.vertex_offset);
}

vec3 vertex_position(uint v) {
    return vec3(vertex_data[8u * v], vertex_data[8u * v + 1u], vertex_data[8u * v + 2u]);
}

vec3 vertex_normal(uint v) {
    return vec3(vertex_data[8u * v + 3u], vertex_data[8u * v + 4u], vertex_data[8u * v + 5u]);
}

vec2 vertex_uv(uint v) {
    return vec2(vertex_data[8u * v + 6u], vertex_data[8u * v + 7u]);
}

vec2 hit_texcoord(uvec3 tri, vec2 b) {
    return vertex_uv(tri.x) * (1.0 - b.x - b.y) + vertex_uv(tri.y) * b.x + vertex_uv(tri.z) * b.y;
}

// Whether the candidate triangle is there at barycentrics b: its material's alpha mask
// (level 0, as the path tracer reads it) reaches the cutoff.
bool mask_keeps(uint draw, uint prim, vec2 b) {
    int mask = materials[instances[rt_draws[draw].instance].material.x].texture.y;
    return mask < 0 || texel(mask, hit_texcoord(triangle_vertices(draw, prim), b)).a >= MASK_CUTOFF;
}

// Runs query q to its end, confirming each masked candidate only where its mask keeps it
// (opaque geometry is committed by the traversal itself). A macro: the query object stays
// the caller's own.
#define RESOLVE_MASKS(q)                                                                         \
    while (rayQueryProceedEXT(q)) {                                                              \
        if (rayQueryGetIntersectionTypeEXT(q, false) != gl_RayQueryCandidateIntersectionTriangleEXT) \
            continue;                                                                            \
        uint cand_draw = rayQueryGetIntersectionInstanceCustomIndexEXT(q, false);                \
        uint cand_prim = rayQueryGetIntersectionPrimitiveIndexEXT(q, false);                     \
        if (mask_keeps(cand_draw, cand_prim, rayQueryGetIntersectionBarycentricsEXT(q, false))) { \
            rayQueryConfirmIntersectionEXT(q);                                                   \
        }                                                                                        \
    }

// The closest surface along o + t d, t in (0, t_max).
bool trace_closest(vec3 o, vec3 d, float t_max, out RayHit h) {
    rayQueryEXT q;
    rayQueryInitializeEXT(q, scene_tlas, gl_RayFlagsNoneEXT, 0xFFu, o, 0.0, d, t_max);
    RESOLVE_MASKS(q);
    h.t = 0.0;
    h.draw = 0u;
    h.prim = 0u;
    h.bary = vec2(0.0);
    if (rayQueryGetIntersectionTypeEXT(q, true) == gl_RayQueryCommittedIntersectionNoneEXT) return false;
    h.t = rayQueryGetIntersectionTEXT(q, true);
    h.draw = rayQueryGetIntersectionInstanceCustomIndexEXT(q, true);
    h.prim = rayQueryGetIntersectionPrimitiveIndexEXT(q, true);
    h.bary = rayQueryGetIntersectionBarycentricsEXT(q, true);
    return true;
}

// Whether anything lies along o + t d, t in (0, t_max).
bool occluded(vec3 o, vec3 d, float t_max) {
    rayQueryEXT q;
    rayQueryInitializeEXT(q, scene_tlas, gl_RayFlagsTerminateOnFirstHitEXT, 0xFFu, o, 0.0, d, t_max);
    RESOLVE_MASKS(q);
    return rayQueryGetIntersectionTypeEXT(q, true) != gl_RayQueryCommittedIntersectionNoneEXT;
}

// The surface at a hit of a ray travelling along d, in world space: normals face the ray.
struct HitSurface {
    vec3 P;
    vec3 ng;
    vec3 ns;
    vec3 albedo;
    vec3 ks;
    float shininess;
    vec3 emission;
};

HitSurface hit_surface(RayHit h, vec3 o, vec3 d) {
    RtDraw draw = rt_draws[h.draw];
    Instance inst = instances[draw.instance];
    uvec3 tri = triangle_vertices(h.draw, h.prim);
    vec3 p0 = (inst.model * vec4(vertex_position(tri.x), 1.0)).xyz;
    vec3 p1 = (inst.model * vec4(vertex_position(tri.y), 1.0)).xyz;
    vec3 p2 = (inst.model * vec4(vertex_position(tri.z), 1.0)).xyz;
    float w = 1.0 - h.bary.x - h.bary.y;
    HitSurface s;
    s.P = o + d * h.t;
    s.ng = safe_normalize(cross(p1 - p0, p2 - p0), -d);
    if (dot(s.ng, d) > 0.0) s.ng = -s.ng;
    vec3 n = vertex_normal(tri.x) * w + vertex_normal(tri.y) * h.bary.x + vertex_normal(tri.z) * h.bary.y;
    s.ns = safe_normalize(mat3(inst.normal) * n, s.ng);
    if (dot(s.ns, s.ng) < 0.0) s.ns = -s.ns;
    Material m = materials[inst.material.x];
    vec3 albedo = m.albedo.rgb;
    if (m.texture.x >= 0) albedo *= texel(m.texture.x, hit_texcoord(tri, h.bary)).rgb;
    s.albedo = clamp(albedo, 0.0, 1.0);
    s.ks = clamp(m.specular.rgb, 0.0, 1.0);
    s.shininess = clamp(m.specular.a, 0.0, HALF_MAX);
    s.emission = min(max(m.emission.rgb, 0.0), vec3(HALF_MAX));
    return s;
}

#endif
