// The sky (scene::sky, render::sky): what a ray that leaves the scene sees. Its parameters are
// a vec4 (FrameData.sky, PtParams.sky): x cos, y sin of its turn about +y, z 1 with a sky.
// Directions map to the equirectangular maps as latitude and longitude about +y: v = theta / pi
// from the zenith, u = phi / 2 pi + 1/2 with phi the azimuth from -z towards +x, turned.
#ifndef DVSGI_SKY_GLSL
#define DVSGI_SKY_GLSL
#include "common.glsl"

// Level 0 of the cone map averages caps of this half-angle (render::sky::ALPHA0); level k
// caps of 2^k times it.
const float SKY_ALPHA0 = PI / 128.0;

bool has_sky(vec4 sky) {
    return sky.z > 0.5;
}

// Image coordinates of unit direction d on the sky turned by (cos, sin) = turn.xy.
vec2 sky_uv(vec3 d, vec2 turn) {
    // The sky turned by a shows at d what the unturned one shows at azimuth phi + a.
    vec2 xz = vec2(turn.x * d.x - turn.y * d.z, turn.x * d.z + turn.y * d.x);
    float u = atan(xz.x, -xz.y) * (0.5 * INV_PI) + 0.5;
    float v = acos(clamp(d.y, -1.0, 1.0)) * INV_PI;
    return vec2(u, v);
}

// The unit direction at image coordinates uv of the sky turned by (cos, sin) = turn.xy: the
// inverse of sky_uv (scene::sky::equirect_dir).
vec3 sky_dir(vec2 uv, vec2 turn) {
    float theta = PI * uv.y;
    float phi = 2.0 * PI * (uv.x - 0.5);
    // The world azimuth is the image's minus the turn.
    float sp = sin(phi) * turn.x - cos(phi) * turn.y;
    float cp = cos(phi) * turn.x + sin(phi) * turn.y;
    float st = sin(theta);
    return vec3(st * sp, cos(theta), -st * cp);
}

// The sky's radiance along d, bilinear: what the camera sees where nothing is in the way.
vec3 sky_radiance(sampler2D map, vec4 sky, vec3 d) {
    if (!has_sky(sky)) return vec3(0.0);
    return textureLod(map, sky_uv(d, sky.xy), 0.0).rgb;
}

// The sky's irradiance / pi on a surface of unit normal n, unoccluded (render::sky's
// irradiance map: the cosine-weighted mean radiance over n's hemisphere).
vec3 sky_irradiance_over_pi(sampler2D irradiance, vec4 sky, vec3 n) {
    if (!has_sky(sky)) return vec3(0.0);
    return textureLod(irradiance, sky_uv(n, sky.xy), 0.0).rgb;
}

// The sky's mean radiance over a cone of half-aperture tangent `tan_half` around d: the cone
// map's level for its aperture, blended between levels by the sampler.
vec3 sky_cone(sampler2D cones, vec4 sky, vec3 d, float tan_half) {
    if (!has_sky(sky)) return vec3(0.0);
    float top = float(textureQueryLevels(cones) - 1);
    float lod = clamp(log2(max(atan(tan_half), 1e-6) / SKY_ALPHA0), 0.0, top);
    return textureLod(cones, sky_uv(d, sky.xy), lod).rgb;
}

#endif
