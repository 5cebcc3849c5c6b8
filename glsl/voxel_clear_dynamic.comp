#version 460
// Before re-voxelizing dynamic objects: empty every voxel not marked static.
#include "voxel.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(constant_id = 2) const bool HAS_EMISSION = false;

layout(set = 0, binding = 0) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 1, r32ui) uniform writeonly uimage3D vox_albedo;
layout(set = 0, binding = 2, r32ui) uniform writeonly uimage3D vox_normal;
layout(set = 0, binding = 3, r32ui) uniform writeonly uimage3D vox_emission;
layout(set = 0, binding = 4, r8ui) uniform readonly uimage3D vox_flags;

void main() {
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(uvec3(c), uvec3(grid.dims.x)))) return;
    if (imageLoad(vox_flags, c).r != 0u) return;
    imageStore(vox_albedo, c, uvec4(0u));
    imageStore(vox_normal, c, uvec4(0u));
    if (HAS_EMISSION) imageStore(vox_emission, c, uvec4(0u));
}
