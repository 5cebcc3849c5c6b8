#version 460
// Supersampling resolve: each output pixel is the mean radiance of its k x k samples (a box
// filter over the pixel, the footprint the reference's jittered paths cover), in linear light
// and before the tone map, so the image's energy is the samples' energy.
layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const int K = 2;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D samples;
layout(set = 0, binding = 1, rgba32f) uniform writeonly image2D resolved;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(resolved)))) return;
    vec4 sum = vec4(0.0);
    for (int y = 0; y < K; ++y) {
        for (int x = 0; x < K; ++x) {
            sum += imageLoad(samples, px * K + ivec2(x, y));
        }
    }
    // A non-finite sample stays non-finite: the tone map shows it as magenta.
    imageStore(resolved, px, sum / float(K * K));
}
