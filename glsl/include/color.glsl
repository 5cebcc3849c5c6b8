// Display transform: exposure, tone map, sRGB encoding (only at the final 8-bit write).
#ifndef DVSGI_COLOR_GLSL
#define DVSGI_COLOR_GLSL

// Narkowicz 2015, "ACES Filmic Tone Mapping Curve" (fit of the ACES RRT+ODT, input scaled 0.6).
vec3 tonemap_aces(vec3 x) {
    x *= 0.6;
    const float a = 2.51, b = 0.03, c = 2.43, d = 0.59, e = 0.14;
    return clamp((x * (a * x + b)) / (x * (c * x + d) + e), 0.0, 1.0);
}

vec3 tonemap_reinhard(vec3 x) {
    return x / (1.0 + x);
}

vec3 tonemap(vec3 x, uint mode) {
    x = max(x, vec3(0.0));
    if (mode == 0u) return tonemap_aces(x);
    if (mode == 1u) return tonemap_reinhard(x);
    return clamp(x, 0.0, 1.0);
}

// IEC 61966-2-1 sRGB encoding of linear [0,1].
vec3 linear_to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 lo = c * 12.92;
    vec3 hi = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;
    return mix(hi, lo, lessThanEqual(c, vec3(0.0031308)));
}

// The 8-bit code of each encoded channel, as a UNORM value: round(c * 255) / 255, an exact
// code. An 8-bit UNORM store may convert the float to 16 bits first and round either way
// (Vulkan allows either neighbouring code); an exact code survives both, so the stored bytes
// are the host's (metrics::display_srgb8) on every device.
vec3 unorm8_code(vec3 c) {
    return floor(clamp(c, 0.0, 1.0) * 255.0 + 0.5) / 255.0;
}

#endif
