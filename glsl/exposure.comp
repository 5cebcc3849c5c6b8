#version 460
// Automatic exposure (`render.exposure = "auto"`), on the GPU so that the window and every
// PNG show what the tone map made of it: the EV that takes the log-average luminance of the
// lit pixels (Rec. 709 luminance > 0, finite) to middle grey, metrics::AUTO_EXPOSURE_KEY, as
// metrics::auto_exposure computes it on the host for path-traced images. Two stages (the
// spec constant): the first sums log2 luminance and counts the lit pixels of each 32 x 32
// tile into `partials` (each invocation 16 pixels in order, then a tree over the 64); RESOLVE,
// one workgroup, sums the tiles and writes the EV into `state`. Both add in a fixed order,
// never with atomics, so the EV is the same bits whatever the order the tiles ran in. (64
// invocations and six barrier rounds: 256 and eight cost lavapipe 18-22 ms a frame at
// 640 x 360, as much as five tone maps.) The viewer eases the shown EV towards each frame's
// (frame.exposure.y < 1), as engines' eye adaptation does; files take it at once.
#include "common.glsl"

layout(constant_id = 0) const bool RESOLVE = false;

layout(local_size_x = 64) in;

layout(set = 0, binding = 0) uniform FrameBlock { FrameData frame; };
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D radiance;
layout(set = 0, binding = 2, std430) buffer Partials { vec2 partials[]; };
// x the EV shown (added to render.exposure), y this frame's own, z lit pixels, w frames.
layout(set = 0, binding = 3, std430) buffer State { vec4 state; };

const float KEY = 0.18;  // mirrors metrics::AUTO_EXPOSURE_KEY

shared vec2 sums[64];

// Sums `sums` over the workgroup, in a fixed tree: the total in sums[0].
void reduce_shared(uint i) {
    for (uint stride = 32u; stride > 0u; stride >>= 1) {
        barrier();
        if (i < stride) sums[i] += sums[i + stride];
    }
    barrier();
}

void main() {
    uint i = gl_LocalInvocationIndex;
    if (!RESOLVE) {
        ivec2 size = imageSize(radiance);
        ivec2 tiles = (size + 31) / 32;
        uint tile = gl_WorkGroupID.x;
        ivec2 corner = ivec2(tile % uint(tiles.x), tile / uint(tiles.x)) * 32;
        vec2 mine = vec2(0.0);
        // Rows i / 32 + 2 k of the tile, column i % 32.
        for (uint k = 0u; k < 16u; ++k) {
            ivec2 px = corner + ivec2(i % 32u, i / 32u + 2u * k);
            if (any(greaterThanEqual(px, size))) continue;
            vec3 c = imageLoad(radiance, px).rgb;
            float y = luminance(c);
            if (!isnan(y) && !isinf(y) && y > 0.0) mine += vec2(log2(y), 1.0);
        }
        sums[i] = mine;
        reduce_shared(i);
        if (i == 0u) partials[tile] = sums[0];
        return;
    }
    ivec2 size = imageSize(radiance);
    ivec2 tiles = (size + 31) / 32;
    uint count = uint(tiles.x * tiles.y);
    vec2 mine = vec2(0.0);
    for (uint t = i; t < count; t += 64u) mine += partials[t];
    sums[i] = mine;
    reduce_shared(i);
    if (i == 0u) {
        vec2 total = sums[0];
        float ev = total.y > 0.0 ? clamp(log2(KEY) - total.x / total.y, -64.0, 64.0) : 0.0;
        // Eased towards this frame's EV in the viewer; the first frame takes it at once.
        float shown = state.w > 0.0 ? mix(state.x, ev, frame.exposure.y) : ev;
        state = vec4(shown, ev, total.y, state.w + 1.0);
    }
}
