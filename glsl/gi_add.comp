#version 460
// `rsm+lpv`: the indirect light is the RSM gather's near field plus the volume's far field.
#include "common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D a;
layout(set = 0, binding = 1, rgba16f) uniform readonly image2D b;
layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D sum;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(sum)))) return;
    vec3 rgb = imageLoad(a, px).rgb + imageLoad(b, px).rgb;
    imageStore(sum, px, vec4(min(rgb, vec3(HALF_MAX)), 1.0));
}
