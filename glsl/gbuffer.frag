#version 460
// G-buffer: linear albedo, normal + shininess, specular, emission. Two-sided: the shading
// normal is turned to the camera's side of the geometric surface, whatever the winding.
#include "common.glsl"
#include "scene.glsl"

layout(constant_id = 0) const uint TEXTURE_COUNT = 1;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 2, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 3) uniform sampler2D textures[TEXTURE_COUNT];

layout(location = 0) in vec3 v_world;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 3) flat in uint v_material;

layout(location = 0) out vec4 out_albedo;    // R8G8B8A8_SRGB: linear written, sRGB stored
layout(location = 1) out vec4 out_normal;    // RGBA16F: world normal, a shininess
layout(location = 2) out vec4 out_specular;  // R8G8B8A8_SRGB: Ks
layout(location = 3) out vec4 out_emission;  // RGBA16F: emitted radiance * radiance scale

void main() {
    Material m = materials[v_material];
    vec3 albedo = m.albedo.rgb;
    int tex = m.texture.x;
    if (tex >= 0 && uint(tex) < TEXTURE_COUNT) {
        albedo *= texture(textures[tex], v_uv).rgb;
    }
    vec3 V = frame.camera_pos.xyz - v_world;
    vec3 ng = safe_normalize(cross(dFdx(v_world), dFdy(v_world)), vec3(0.0));
    if (dot(ng, V) < 0.0) ng = -ng;
    vec3 n = safe_normalize(v_normal, ng);
    if (dot(ng, ng) > 0.0 && dot(n, ng) < 0.0) n = -n;
    out_albedo = vec4(clamp(albedo, 0.0, 1.0), 1.0);
    out_normal = vec4(n, clamp(m.specular.a, 0.0, HALF_MAX));
    out_specular = vec4(clamp(m.specular.rgb, 0.0, 1.0), 1.0);
    out_emission = vec4(min(max(m.emission.rgb, 0.0) * frame.radiance_scale.x, vec3(HALF_MAX)), 1.0);
}
