#version 460
// Display transform: radiance * 2^EV (render.exposure, plus exposure.comp's EV where it is
// "auto"), tone map, sRGB encode into the 8-bit output.
#include "common.glsl"
#include "color.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D in_radiance;
layout(set = 0, binding = 2, rgba8) uniform writeonly image2D out_display;
// exposure.comp's result: x the EV "auto" adds (read only where frame.exposure.x is 1).
layout(set = 0, binding = 3, std430) readonly buffer Exposure { vec4 auto_exposure; };

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(out_display)))) return;
    vec3 c = imageLoad(in_radiance, px).rgb;
    // Non-finite radiance shows as magenta, never silently as black or white.
    if (any(isnan(c)) || any(isinf(c))) {
        imageStore(out_display, px, vec4(1.0, 0.0, 1.0, 1.0));
        return;
    }
    float scale = frame.shadow.w * (frame.exposure.x > 0.5 ? exp2(auto_exposure.x) : 1.0);
    vec3 mapped = tonemap(c * scale, frame.counts.w);
    imageStore(out_display, px, vec4(unorm8_code(linear_to_srgb(mapped)), 1.0));
}
