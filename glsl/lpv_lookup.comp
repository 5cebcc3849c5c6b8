#version 460
// Light propagation volume lookup per traced pixel: the summed intensity SH, trilinearly
// interpolated half a cell in front of the surface (against self-lighting), is read as
// radiance L = I/cell^2. The radiance is reconstructed in DIRS cosine-distributed directions
// of the pixel's hemisphere, clamped at zero, and averaged: E = pi/DIRS sum max(0, L).
// Clamping the radiance, not the irradiance, matters. A two-band lobe is negative behind
// itself, so the linear E = SH(L) . lobe(-N) would let a lit surface's own upward lobes
// subtract from the light it receives (-0.26 of their flux). Writes E/pi (times the radiance
// scale) like the cone tracer, with a = 1 (no AO).
#include "common.glsl"
#include "cone_params.glsl"
#include "gbuffer_read.glsl"
#include "sh.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1) uniform GiBlock { GiParams gi; };
layout(set = 0, binding = 2) uniform GridBlock { LpvGrid grid; };
layout(set = 0, binding = 3) uniform sampler2D g_depth;
layout(set = 0, binding = 4) uniform sampler2D g_normal;
layout(set = 0, binding = 5) uniform sampler3D sum_r;
layout(set = 0, binding = 6) uniform sampler3D sum_g;
layout(set = 0, binding = 7) uniform sampler3D sum_b;
layout(set = 0, binding = 8, rgba16f) uniform writeonly image2D out_diffuse;

const uint DIRS = 32u;

// The i-th of DIRS cosine-distributed directions around +z (a Hammersley set).
vec3 cosine_direction(uint i) {
    float u = (float(i) + 0.5) / float(DIRS);
    float phi = 2.0 * PI * float(bitfieldReverse(i)) * (1.0 / 4294967296.0);
    float r = sqrt(u);
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u, 0.0)));
}

void main() {
    ivec2 lo = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(lo, imageSize(out_diffuse)))) return;
    int k = int(gi.counts.y);
    ivec2 px = min(lo * k + k / 2, ivec2(frame.counts.xy) - 1);
    float depth = texelFetch(g_depth, px, 0).r;
    if (depth >= 1.0) {
        imageStore(out_diffuse, lo, vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    vec3 P = world_position(frame, px, depth);
    vec3 N = safe_normalize(texelFetch(g_normal, px, 0).xyz, vec3(0.0, 1.0, 0.0));
    float s = grid.origin.w;
    vec3 uvw = (P + 0.5 * s * N - grid.origin.xyz) / (s * float(grid.dims.x));
    vec4 r = texture(sum_r, uvw), g = texture(sum_g, uvw), b = texture(sum_b, uvw);
    mat3 frame_n = tangent_frame(N);
    vec3 sum = vec3(0.0);
    for (uint i = 0u; i < DIRS; ++i) {
        vec4 y = sh_eval(-(frame_n * cosine_direction(i)));  // light travelling towards the surface
        sum += max(vec3(dot(r, y), dot(g, y), dot(b, y)), vec3(0.0));
    }
    // E = pi/DIRS sum L; the target holds E/pi, and L = I / cell^2.
    vec3 mean_radiance = sum / (float(DIRS) * s * s) * frame.radiance_scale.x;
    imageStore(out_diffuse, lo, vec4(min(mean_radiance, vec3(HALF_MAX)), 1.0));
}
