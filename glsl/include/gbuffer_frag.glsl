// G-buffer: linear albedo, normal + shininess, specular, emission. Two-sided: the shading
// normal is turned to the camera's side of the geometric surface, whatever the winding.
// Alpha-masked materials are cut out; normal and height maps bend the shading normal.
// Included by gbuffer.frag and, with GBUFFER_NO_EMISSION defined (no emissive material in the
// scene: no emission target), by gbuffer_no_emission.frag.
#ifndef DVSGI_GBUFFER_FRAG_GLSL
#define DVSGI_GBUFFER_FRAG_GLSL
#include "common.glsl"
#include "scene.glsl"
#include "material.glsl"

layout(constant_id = 0) const uint TEXTURE_COUNT = 1;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 2, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 3) uniform texture2D textures[TEXTURE_COUNT];
layout(set = 0, binding = 4) uniform sampler texture_sampler;

layout(location = 0) in vec3 v_world;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 3) flat in uint v_material;

layout(location = 0) out vec4 out_albedo;    // R8G8B8A8_SRGB: linear written, sRGB stored;
                                             //   a: geometric normal, octahedral x
layout(location = 1) out vec4 out_normal;    // RGBA16F: world normal (a footprint's mean: up to
                                             //   unit length), a shininess (Toksvig)
layout(location = 2) out vec4 out_specular;  // R8G8B8A8_SRGB: Ks; a: geometric normal, oct. y
#ifndef GBUFFER_NO_EMISSION
layout(location = 3) out vec4 out_emission;  // RGBA16F: emitted radiance * radiance scale
#endif

bool has(int tex) {
    return tex >= 0 && uint(tex) < TEXTURE_COUNT;
}

// The shading normal bent by the material's normal or height map: the mean over the pixel's
// footprint (material.glsl: `filtered_normal`, unnormalized), in the pixel's UV frame.
vec3 bent_normal(Material m, vec3 n, vec3 ng, vec3 dpdx, vec3 dpdy, vec2 duvdx, vec2 duvdy) {
    int tex = m.texture.z;
    if (!has(tex) || m.texture.w == 0) return n;
    UvFrame f = uv_frame(dpdx, dpdy, duvdx, duvdy);
    vec3 mean = filtered_normal(textures[tex], texture_sampler, m.texture.w, n, f, v_uv, duvdx, duvdy, m.emission.a);
    return keep_facing(mean, n, ng);
}

void main() {
    Material m = materials[v_material];
    vec3 dpdx = dFdx(v_world), dpdy = dFdy(v_world);
    vec2 duvdx = dFdx(v_uv), duvdy = dFdy(v_uv);
    if (has(m.texture.y) && textureGrad(SCENE_TEXTURE(m.texture.y), v_uv, duvdx, duvdy).a < MASK_CUTOFF) discard;
    vec3 albedo = m.albedo.rgb;
    int tex = m.texture.x;
    if (has(tex)) {
        albedo *= textureGrad(SCENE_TEXTURE(tex), v_uv, duvdx, duvdy).rgb;
    }
    vec3 V = frame.camera_pos.xyz - v_world;
    vec3 ng = safe_normalize(cross(dpdx, dpdy), vec3(0.0));
    if (dot(ng, V) < 0.0) ng = -ng;
    vec3 n = safe_normalize(v_normal, ng);
    if (dot(ng, ng) > 0.0 && dot(n, ng) < 0.0) n = -n;
    n = bent_normal(m, n, ng, dpdx, dpdy, duvdx, duvdy);
    // The geometric normal rides in the two alpha channels: light from behind the surface
    // itself is blocked whatever the shading normal says, as in the path tracer.
    vec2 facing = oct_encode(dot(ng, ng) > 0.0 ? ng : n);
    out_albedo = vec4(clamp(albedo, 0.0, 1.0), facing.x);
    // The normal is the footprint's mean: deferred_light.comp's diffuse reads its length.
    out_normal = vec4(n, clamp(toksvig_shininess(m.specular.a, length(n)), 0.0, HALF_MAX));
    out_specular = vec4(clamp(m.specular.rgb, 0.0, 1.0), facing.y);
#ifndef GBUFFER_NO_EMISSION
    out_emission = vec4(min(max(m.emission.rgb, 0.0) * frame.radiance_scale.x, vec3(HALF_MAX)), 1.0);
#endif
}

#endif
