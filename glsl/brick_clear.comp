#version 460
// Empties the slots of the dynamic bricks (bricks.glsl) once they are allocated, before the
// dynamic objects are voxelized into them: each dynamic update hands those slots out anew, so a
// slot may last have held another brick. Pool 0: the full-resolution volumes (8^3 texels per
// slot; 9^3 with the apron for the sampled radiance volumes); pools 1..: the six directional
// volumes of their level (9^3 per slot, apron included).
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(constant_id = 0) const int POOL = 0;
layout(constant_id = 1) const bool HAS_SCRATCH = false;

layout(set = 0, binding = 0) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 1, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"
#define BRICK_LIST_BINDING 2
#define BRICK_LIST_QUALIFIER readonly
#include "brick_list.glsl"
// Albedo, normal, emission (or albedo again); the sampled radiance, bounced (or radiance again).
layout(set = 0, binding = 3, r32ui) uniform writeonly uimage3D full_words[3];
layout(set = 0, binding = 4, rgba16f) uniform writeonly image3D full_radiance[2];
// The six directional volumes of pool POOL's level (placeholders for pool 0).
layout(set = 0, binding = 5, rgba16f) uniform writeonly image3D faces[6];
// The bounce's scratch volume (8^3 per slot; a placeholder, untouched, without bounces).
layout(set = 0, binding = 6, rgba16f) uniform writeonly image3D full_scratch;

void main() {
    uint slot = brick_dynamic_slot(POOL);
    if (slot == ~0u) return;
    uint block = gl_WorkGroupID.y % 8u;
    ivec3 t = ivec3(gl_LocalInvocationID) + 4 * ivec3(block & 1u, (block >> 1) & 1u, block >> 2);
    if (POOL == 0) {
        ivec3 p = slot_texel(0, slot, 8) + t;
        for (int k = 0; k < 3; ++k) imageStore(full_words[k], p, uvec4(0u));
        if (HAS_SCRATCH) imageStore(full_scratch, p, vec4(0.0));
    }
    // 8^3 invocations for 9^3 texels: the last one on an axis also takes texel 8.
    ivec3 last = ivec3(equal(t, ivec3(7)));
    ivec3 origin = slot_texel(POOL, slot, 9);
    for (int z = 0; z <= last.z; ++z) {
        for (int y = 0; y <= last.y; ++y) {
            for (int x = 0; x <= last.x; ++x) {
                ivec3 p = origin + t + ivec3(x, y, z);
                if (POOL == 0) {
                    for (int k = 0; k < 2; ++k) imageStore(full_radiance[k], p, vec4(0.0));
                } else {
                    for (int f = 0; f < 6; ++f) imageStore(faces[f], p, vec4(0.0));
                }
            }
        }
    }
}
