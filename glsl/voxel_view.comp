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

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(px), frame.counts.xy))) return;
    GridRay ray = camera_grid_ray(frame, grid, px);
    vec3 o = ray.o, d = ray.d;
    float tenter = ray.tenter, texit = ray.texit;
    float res = float(grid.dims.x);
    vec3 inv = 1.0 / d;
    vec4 result = vec4(0.0, 0.0, 0.0, 1.0);
    if (tenter < texit) {
        vec3 p = o + d * (tenter + 1e-4);
        ivec3 c = clamp(ivec3(floor(p)), ivec3(0), ivec3(int(res) - 1));
        ivec3 stp = ivec3(sign(d));
        vec3 next = (vec3(c) + max(vec3(stp), vec3(0.0)) - o) * inv;
        vec3 delta = abs(inv);
        for (int i = 0; i < 3 * 512; ++i) {
            uint v = imageLoad(volume, c).r;
            if ((v >> 24) != 0u) {
                vec3 rgb = unpack_rgb_count(v).rgb / 255.0;
                result.rgb = MODE == 2u ? rgb * grid.params.x : (MODE == 3u ? vec3(0.0) : rgb);
                if (MODE == 4u) result.rgb = imageLoad(vox_radiance, c).rgb * grid.params.z;
                break;
            }
            if (next.x < next.y && next.x < next.z) {
                c.x += stp.x;
                next.x += delta.x;
            } else if (next.y < next.z) {
                c.y += stp.y;
                next.y += delta.y;
            } else {
                c.z += stp.z;
                next.z += delta.z;
            }
            if (any(lessThan(c, ivec3(0))) || any(greaterThanEqual(c, ivec3(int(res))))) break;
        }
    }
    imageStore(out_radiance, px, result);
}
