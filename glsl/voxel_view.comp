#version 460
// Debug view: march each camera ray through the voxel grid (3D DDA) and show the first
// non-empty voxel's albedo, normal (0.5 + 0.5 n) or emitted radiance.
#include "common.glsl"
#include "voxel.glsl"
#include "grid_ray.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const uint MODE = 0;  // 0 albedo, 1 normal, 2 emission, 3 none (black), 4 radiance

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 2, r32ui) uniform readonly uimage3D volume;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D out_radiance;
layout(set = 0, binding = 4, rgba16f) uniform readonly image3D vox_radiance;
layout(set = 0, binding = 5, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(px), frame.counts.xy))) return;
    GridRay ray = camera_grid_ray(frame, grid, px);
    vec3 o = ray.o, d = ray.d;
    float tenter = ray.tenter, texit = ray.texit;
    float res = float(grid.dims.x);
    vec4 result = vec4(0.0, 0.0, 0.0, 1.0);
    if (tenter < texit) {
        // Just inside the grid (the entry point may round onto its far side).
        vec3 p = clamp(o + d * (tenter + 1e-4), vec3(0.0), vec3(res - 1e-3));
        VoxelWalk w = voxel_walk(p, d);
        for (int i = 0; i < 3 * 512; ++i) {
            ivec3 t = full_texel(w.c);
            uint v = t.x < 0 ? 0u : imageLoad(volume, t).r;
            if ((v >> 24) != 0u) {
                vec3 rgb = unpack_rgb_count(v).rgb / 255.0;
                result.rgb = MODE == 2u ? rgb * grid.params.x : (MODE == 3u ? vec3(0.0) : rgb);
                if (MODE == 4u) result.rgb = imageLoad(vox_radiance, radiance_texel(w.c)).rgb * grid.params.z;
                break;
            }
            if (!voxel_walk_step(w, int(res))) break;
        }
    }
    imageStore(out_radiance, px, result);
}
