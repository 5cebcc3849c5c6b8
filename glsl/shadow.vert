#version 460
// Depth-only render of the scene into one shadow view (a layer of the shadow array).
#include "scene.glsl"
#include "shadow.glsl"

layout(location = 0) in vec3 in_position;

layout(set = 0, binding = 0, std430) readonly buffer Instances { Instance instances[]; };
layout(set = 0, binding = 1, std430) readonly buffer ShadowViews { ShadowView views[]; };

layout(push_constant) uniform Push { uint view; } pc;

void main() {
    vec4 world = instances[gl_InstanceIndex].model * vec4(in_position, 1.0);
    gl_Position = views[pc.view].view_proj * world;
}
