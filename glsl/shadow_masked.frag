#version 460
// Alpha test of a masked draw in the shadow maps: a leaf casts a leaf-shaped shadow.
#include "scene.glsl"
#include "material.glsl"

layout(constant_id = 0) const uint TEXTURE_COUNT = 1;

layout(set = 0, binding = 2, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 3) uniform texture2D textures[TEXTURE_COUNT];
layout(set = 0, binding = 4) uniform sampler texture_sampler;

layout(location = 0) in vec2 v_uv;
layout(location = 1) flat in uint v_material;

void main() {
    int mask = materials[v_material].texture.y;
    if (mask >= 0 && uint(mask) < TEXTURE_COUNT && texture(SCENE_TEXTURE(mask), v_uv).a < MASK_CUTOFF) discard;
}
