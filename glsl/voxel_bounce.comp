#version 460
// One light bounce in the voxels: every occupied voxel traces the diffuse cones over its
// normal's hemisphere through the current radiance (full-resolution volume + directional
// mips) and adds the reflected light to its direct radiance:
//   L = L_direct + albedo/pi * E,   E = pi * sum_i w_i L_i   =>   L = L_direct + albedo * sum_i w_i L_i
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(set = 0, binding = 0) uniform GridBlock { VoxelGrid grid; };
#include "cone_params.glsl"
layout(set = 0, binding = 1) uniform GiBlock { GiParams gi; };
layout(set = 0, binding = 2) uniform sampler3D vox_lod0;
layout(set = 0, binding = 3) uniform sampler3D aniso[6];
layout(set = 0, binding = 4, r32ui) uniform readonly uimage3D vox_albedo;
layout(set = 0, binding = 5, r32ui) uniform readonly uimage3D vox_normal;
layout(set = 0, binding = 6) uniform sampler3D vox_direct;
layout(set = 0, binding = 7, rgba16f) uniform writeonly image3D vox_out;
#include "cone.glsl"

void main() {
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(c, ivec3(grid.dims.x)))) return;
    uint a = imageLoad(vox_albedo, c).r;
    if ((a >> 24) == 0u) {
        imageStore(vox_out, c, vec4(0.0));
        return;
    }
    vec3 albedo = unpack_rgb_count(a).rgb / 255.0;
    vec3 n_avg = unpack_rgb_count(imageLoad(vox_normal, c).r).rgb / 255.0 * 2.0 - 1.0;
    vec3 N = safe_normalize(n_avg, vec3(0.0, 1.0, 0.0));
    vec4 d = trace_diffuse(ConeOrigin(vec3(c) + 0.5, N, 0.5));
    vec4 direct = texelFetch(vox_direct, c, 0);
    imageStore(vox_out, c, vec4(min(direct.rgb + albedo * d.rgb, vec3(HALF_MAX)), 1.0));
}
