#version 460
// Debug view of the radiance volumes exactly as the cone tracer samples them: each camera
// ray marches the grid at a fixed level of detail, sampling in a fixed direction (one of the
// six directional volumes) or along the ray, and composites front to back.
#include "common.glsl"
#include "voxel.glsl"
#include "grid_ray.glsl"
#include "cone_params.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// 0: along the camera ray; 1..6: +x, -x, +y, -y, +z, -z.
layout(constant_id = 0) const uint DIRECTION = 0;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 2) uniform GiBlock { GiParams gi; };
layout(set = 0, binding = 3) uniform sampler3D vox_lod0;
layout(set = 0, binding = 4) uniform sampler3D aniso[6];
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D out_radiance;
layout(set = 0, binding = 6, r32ui) uniform readonly uimage3D brick_maps[4];
layout(set = 0, binding = 7) uniform texture3D aniso_pool[18];
layout(set = 0, binding = 8) uniform sampler pool_sampler;
#include "cone.glsl"

layout(push_constant) uniform Push { float lod; } pc;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(px), frame.counts.xy))) return;
    GridRay ray = camera_grid_ray(frame, grid, px);
    vec3 o = ray.o, d = ray.d;
    const vec3 axes[7] = vec3[7](vec3(0.0), vec3(1, 0, 0), vec3(-1, 0, 0), vec3(0, 1, 0), vec3(0, -1, 0),
                                 vec3(0, 0, 1), vec3(0, 0, -1));
    vec3 sdir = DIRECTION == 0u ? d : axes[DIRECTION];
    float step = 0.5 * exp2(max(pc.lod, 0.0));
    vec3 color = vec3(0.0);
    float alpha = 0.0;
    for (float t = ray.tenter + 0.5 * step; t < ray.texit && alpha < 0.995; t += step) {
        vec4 seg = cone_segment(sample_voxels(o + d * t, sdir, pc.lod), 0.5);
        color += (1.0 - alpha) * seg.rgb;
        alpha += (1.0 - alpha) * seg.a;
    }
    imageStore(out_radiance, px, vec4(color * grid.params.z, 1.0));  // volumes hold radiance * scale
}
