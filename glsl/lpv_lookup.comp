#version 460
// Light propagation volume lookup per traced pixel: the summed intensity SH, trilinearly
// interpolated half a cell in front of the surface (against self-lighting), read as radiance
// I/cell^2, gives the irradiance E = SH(L) . lobe(-N). Writes E/pi (times the radiance scale)
// like the cone tracer, with a = 1 (no AO).
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
    vec4 lobe = cos_lobe(-N) / (s * s);
    vec3 e = vec3(dot(texture(sum_r, uvw), lobe), dot(texture(sum_g, uvw), lobe), dot(texture(sum_b, uvw), lobe));
    vec3 mean_radiance = max(e, vec3(0.0)) / PI * frame.radiance_scale.x;
    imageStore(out_diffuse, lo, vec4(min(mean_radiance, vec3(HALF_MAX)), 1.0));
}
