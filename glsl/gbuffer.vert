#version 460
// G-buffer: transform scene vertices by their instance's model matrix.
#include "common.glsl"
#include "scene.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, std430) readonly buffer Instances { Instance instances[]; };

layout(location = 0) out vec3 v_world;
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec2 v_uv;
layout(location = 3) flat out uint v_material;
// The depth prepass and the G-buffer over it (render.depth_prepass) are different pipelines of
// this shader: their depths must be equal bit for bit.
invariant gl_Position;

void main() {
    Instance inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(in_position, 1.0);
    v_world = world.xyz;
    v_normal = mat3(inst.normal) * in_normal;
    v_uv = in_uv;
    v_material = inst.material.x;
    gl_Position = frame.view_proj * world;
}
