#version 460
// Reflective shadow map texel (Dachsbacher & Stamminger 2005): the surface the light sees
// through this texel as a small Lambertian area light. Flux = albedo * E * A, with E the
// light's irradiance on the surface (cosine included) and A the surface area the texel covers
// (|dP/dx x dP/dy|), so the flux is independent of the map's resolution and projection.
// Alpha-masked materials are cut out as in the G-buffer and the shadow maps.
#include "common.glsl"
#include "scene.glsl"
#include "material.glsl"
#define SHADOW_VIEWS_BINDING 1
#include "shadow.glsl"

layout(constant_id = 0) const uint TEXTURE_COUNT = 1;

layout(set = 0, binding = 2, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 3) uniform texture2D textures[TEXTURE_COUNT];
layout(set = 0, binding = 4) uniform sampler texture_sampler;
layout(set = 0, binding = 5, std430) readonly buffer Lights { Light lights[]; };

layout(push_constant) uniform Push { uvec4 view; } pc;  // x shadow view, y light

layout(location = 0) in vec3 v_world;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 3) flat in uint v_material;

layout(location = 0) out vec4 out_flux;      // RGBA32F: rgb flux (W), a texel area (m^2)
layout(location = 1) out vec4 out_normal;    // RGBA16F: unit normal on the light's side
layout(location = 2) out vec4 out_position;  // RGBA32F: world position

bool has(int tex) {
    return tex >= 0 && uint(tex) < TEXTURE_COUNT;
}

void main() {
    Material m = materials[v_material];
    vec3 dpdx = dFdx(v_world), dpdy = dFdy(v_world);
    vec2 duvdx = dFdx(v_uv), duvdy = dFdy(v_uv);
    if (has(m.texture.y) && textureGrad(SCENE_TEXTURE(m.texture.y), v_uv, duvdx, duvdy).a < MASK_CUTOFF) discard;
    Light l = lights[pc.view.y];
    // A point light's cube faces overlap by the PCF margin: each surface belongs to one face.
    if (l.shadow.y == 6 && shadow_view_index(l, v_world, 0.0, 1.0) != int(pc.view.x)) discard;
    vec3 albedo = m.albedo.rgb;
    if (has(m.texture.x)) albedo *= textureGrad(SCENE_TEXTURE(m.texture.x), v_uv, duvdx, duvdy).rgb;
    LightSample s = sample_light(l, v_world);
    vec3 ng = safe_normalize(cross(dpdx, dpdy), s.wi);
    vec3 n = safe_normalize(v_normal, ng);
    if (dot(n, s.wi) < 0.0) n = -n;
    float area = length(cross(dpdx, dpdy));
    vec3 flux = clamp(albedo, 0.0, 1.0) * s.irradiance * max(dot(n, s.wi), 0.0) * area;
    out_flux = vec4(flux, max(area, 1e-30));
    out_normal = vec4(n, 0.0);
    out_position = vec4(v_world, 1.0);
}
