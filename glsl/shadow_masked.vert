#version 460
// Depth-only render of alpha-masked draws into one shadow view: shadow.vert, plus the UV and
// material that shadow_masked.frag cuts with.
#include "scene.glsl"
#include "shadow.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 2) in vec2 in_uv;

layout(set = 0, binding = 0, std430) readonly buffer Instances { Instance instances[]; };
layout(set = 0, binding = 1, std430) readonly buffer ShadowViews { ShadowView views[]; };

layout(push_constant) uniform Push { uint view; } pc;

layout(location = 0) out vec2 v_uv;
layout(location = 1) flat out uint v_material;

void main() {
    Instance inst = instances[gl_InstanceIndex];
    gl_Position = views[pc.view].view_proj * (inst.model * vec4(in_position, 1.0));
    v_uv = in_uv;
    v_material = inst.material.x;
}
