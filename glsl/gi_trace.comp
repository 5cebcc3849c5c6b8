#version 460
// Per-pixel cone tracing from the G-buffer, at 1/k of the image resolution (each traced pixel
// takes the centre pixel of its k x k block):
//   diffuse:  rgb = cosine-weighted mean incoming radiance (irradiance / pi), a = AO factor
//   specular: rgb = radiance along the mirror direction, cone from the Blinn-Phong exponent
//   shadow:   visibility of lights 0..3 through a cone toward each (soft shadows)
#include "common.glsl"
#include "lights.glsl"
#include "voxel.glsl"
#include "cone_params.glsl"
#include "gbuffer_read.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const bool HAS_SPECULAR = false;
layout(constant_id = 1) const bool CONE_SHADOWS = false;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, std430) readonly buffer Lights { Light lights[]; };
layout(set = 0, binding = 2) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 3) uniform GiBlock { GiParams gi; };
layout(set = 0, binding = 4) uniform sampler2D g_depth;
layout(set = 0, binding = 5) uniform sampler2D g_normal;
layout(set = 0, binding = 6) uniform sampler2D g_specular;
layout(set = 0, binding = 7) uniform sampler3D vox_lod0;
layout(set = 0, binding = 8) uniform sampler3D aniso[6];
layout(set = 0, binding = 9, rgba16f) uniform writeonly image2D out_diffuse;
layout(set = 0, binding = 10, rgba16f) uniform writeonly image2D out_specular;
layout(set = 0, binding = 11, rgba8) uniform writeonly image2D out_shadow;
#include "cone.glsl"

// Half aperture of the specular cone for Blinn-Phong exponent n: the cone holding half the
// energy of the equivalent Phong lobe (exponent n/4, energy within angle a of the mirror
// direction 1 - cos^(n/4+1) a), clamped to 0.25..85 degrees.
float specular_tan_half(float n) {
    float a = acos(pow(0.5, 1.0 / (max(n, 0.0) / 4.0 + 1.0)));
    return tan(clamp(a, radians(0.25), radians(85.0)));
}

void main() {
    ivec2 lo = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(lo, imageSize(out_diffuse)))) return;
    int k = int(gi.counts.y);
    ivec2 px = min(lo * k + k / 2, ivec2(frame.counts.xy) - 1);
    float depth = texelFetch(g_depth, px, 0).r;
    if (depth >= 1.0) {
        imageStore(out_diffuse, lo, vec4(0.0, 0.0, 0.0, 1.0));
        if (HAS_SPECULAR) imageStore(out_specular, lo, vec4(0.0));
        if (CONE_SHADOWS) imageStore(out_shadow, lo, vec4(1.0));
        return;
    }
    vec3 P = world_position(frame, px, depth);
    vec4 ns = texelFetch(g_normal, px, 0);
    vec3 N = safe_normalize(ns.xyz, vec3(0.0, 1.0, 0.0));
    float voxel = grid.origin.w;
    vec3 g = (P - grid.origin.xyz) / voxel + N * gi.trace.z;

    vec4 diffuse = trace_diffuse(g, N);
    if ((gi.counts.w & GI_FLAG_AO) == 0u) diffuse.a = 1.0;
    imageStore(out_diffuse, lo, diffuse);

    if (HAS_SPECULAR) {
        vec3 ks = texelFetch(g_specular, px, 0).rgb;
        vec3 spec = vec3(0.0);
        if (max(ks.r, max(ks.g, ks.b)) > 0.0) {
            vec3 V = safe_normalize(frame.camera_pos.xyz - P, N);
            vec3 R = reflect(-V, N);
            spec = trace_cone(g, R, specular_tan_half(ns.a), 1e30).radiance;
        }
        imageStore(out_specular, lo, vec4(spec, 1.0));
    }

    if (CONE_SHADOWS) {
        vec4 vis = vec4(1.0);
        for (uint i = 0u; i < min(frame.counts.z, 4u); ++i) {
            Light l = lights[i];
            if (l.shadow.x < 0) continue;
            LightSample s = sample_light(l, P);
            if (dot(s.wi, N) <= 0.0) continue;
            // Also step off along the light direction: at grazing angles the cone would
            // otherwise run through the surface's own voxels.
            vec3 gs = g + s.wi * gi.trace.z;
            float dist = s.distance > 0.0 ? s.distance / voxel - 2.0 * gi.trace.z : 1e30;
            vis[i] = 1.0 - trace_cone(gs, s.wi, gi.shadow.x, dist).opacity;
        }
        imageStore(out_shadow, lo, vis);
    }
}
