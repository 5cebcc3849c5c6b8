#version 460
// Reflective shadow map: the scene from one shadow view of a light (rsm.frag writes what
// each visible surface reflects).
#include "common.glsl"
#include "scene.glsl"
#include "shadow.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(set = 0, binding = 0, std430) readonly buffer Instances { Instance instances[]; };
layout(set = 0, binding = 1, std430) readonly buffer ShadowViews { ShadowView views[]; };

layout(push_constant) uniform Push { uvec4 view; } pc;  // x shadow view, y light

layout(location = 0) out vec3 v_world;
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec2 v_uv;
layout(location = 3) flat out uint v_material;

void main() {
    Instance inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(in_position, 1.0);
    v_world = world.xyz;
    v_normal = mat3(inst.normal) * in_normal;
    v_uv = in_uv;
    v_material = inst.material.x;
    gl_Position = views[pc.view.x].view_proj * world;
}
