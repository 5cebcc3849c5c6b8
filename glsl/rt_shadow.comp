#version 460
// Ray-traced shadows of the direct light (gi.shadows = "rt"), at full resolution: for every
// pixel, the visibility (0 or 1) of each of the first four lights, in the channels of the same
// visibility image the shadow cones write, which the lighting pass reads in place of the shadow
// maps. One ray from the pixel's surface point (where the rasterizer sampled it, as the path
// tracer's rays leave) towards the light, stopped just short of a point or spot light; alpha
// masks cut surfaces exactly as the path tracer's (ray_query.glsl). Lights that cast no shadows,
// face away from the surface or give it no light are left at 1 (the lighting pass skips them).
#extension GL_EXT_ray_query : require
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "lights.glsl"
#include "gbuffer_read.glsl"
#include "scene.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const uint TEXTURE_COUNT = 1;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, std430) readonly buffer Lights { Light lights[]; };
layout(set = 0, binding = 2) uniform sampler2D g_depth;
layout(set = 0, binding = 3) uniform sampler2D g_albedo;
layout(set = 0, binding = 4) uniform sampler2D g_specular;
layout(set = 0, binding = 5, rgba8) uniform writeonly image2D out_visibility;
layout(set = 0, binding = 6) uniform accelerationStructureEXT scene_tlas;
layout(set = 0, binding = 7, std430) readonly buffer Vertices { float vertex_data[]; };
layout(set = 0, binding = 8, std430) readonly buffer Indices { uint index_data[]; };
layout(set = 0, binding = 9, std430) readonly buffer Draws { RtDraw rt_draws[]; };
layout(set = 0, binding = 10, std430) readonly buffer Instances { Instance instances[]; };
layout(set = 0, binding = 11, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 12) uniform texture2D textures[TEXTURE_COUNT];
layout(set = 0, binding = 13) uniform sampler texture_sampler;
#include "ray_query.glsl"

// Offset along the geometric normal that keeps a ray off the surface it leaves: a hundredth of
// the pixel's footprint at P, plus the float precision of P's coordinates. Measured against the
// path tracer's direct light: at a thousandth the depth buffer's reconstruction error shades the
// floor of cornell-sphere by its own surface; at a tenth rays from the ceiling beside the light's
// quad pass under its edge where the path tracer's pass over it.
float ray_offset(vec3 P) {
    float footprint = 2.0 * distance(P, frame.camera_pos.xyz) / (abs(frame.proj[1][1]) * float(frame.counts.y));
    return 0.01 * footprint + 1e-5 * max(abs(P.x), max(abs(P.y), abs(P.z)));
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(px), frame.counts.xy))) return;
    vec4 vis = vec4(1.0);
    float depth = texelFetch(g_depth, px, 0).r;
    if (depth < 1.0) {
        vec3 P = world_position(frame, px, depth);
        vec3 ng = oct_decode(vec2(texelFetch(g_albedo, px, 0).a, texelFetch(g_specular, px, 0).a));
        float eps = ray_offset(P);
        vec3 origin = P + ng * eps;
        uint count = min(frame.counts.z, 4u);
        for (uint i = 0u; i < count; ++i) {
            Light l = lights[i];
            if (l.shadow.x < 0) continue;
            LightSample s = sample_light(l, P);
            if (dot(ng, s.wi) <= 0.0 || max(s.irradiance.r, max(s.irradiance.g, s.irradiance.b)) <= 0.0) continue;
            float reach = s.distance > 0.0 ? s.distance * (1.0 - 1e-5) - 2.0 * eps : 1e30;
            if (reach > 0.0 && occluded(origin, s.wi, reach)) vis[i] = 0.0;
        }
    }
    imageStore(out_visibility, px, vis);
}
