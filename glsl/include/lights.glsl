// Light evaluation shared by every lighting pass (mirrors render::lights::GpuLight).
// Units: directional `color` is irradiance W/m^2 on a surface facing the light;
// point and spot `color` is intensity W/sr.
#ifndef DVSGI_LIGHTS_GLSL
#define DVSGI_LIGHTS_GLSL
#include "common.glsl"

const uint LIGHT_DIRECTIONAL = 0u;
const uint LIGHT_POINT = 1u;
const uint LIGHT_SPOT = 2u;

struct Light {
    vec4 position;   // xyz position (point/spot), w type
    vec4 direction;  // xyz direction the light travels (directional/spot)
    vec4 color;      // rgb irradiance (directional) or intensity (point/spot)
    vec4 cone;       // x cos(inner), y cos(outer)
    ivec4 shadow;    // x first shadow view or -1, y view count (1 or 6)
};

struct LightSample {
    vec3 wi;          // unit vector from the surface towards the light
    float distance;   // to the light (0 for directional)
    vec3 irradiance;  // W/m^2 on a surface facing the light (before the cosine)
};

// `min_distance`: point and spot lights are evaluated no nearer than this.
LightSample sample_light_near(Light l, vec3 P, float min_distance) {
    LightSample s;
    uint type = uint(l.position.w);
    if (type == LIGHT_DIRECTIONAL) {
        s.wi = -safe_normalize(l.direction.xyz, vec3(0.0, -1.0, 0.0));
        s.distance = 0.0;
        s.irradiance = l.color.rgb;
        return s;
    }
    vec3 d = l.position.xyz - P;
    float d2 = max(dot(d, d), max(min_distance * min_distance, 1e-12));
    s.distance = sqrt(d2);
    s.wi = d / s.distance;
    s.irradiance = l.color.rgb / d2;
    if (type == LIGHT_SPOT) {
        float cos_theta = dot(-s.wi, safe_normalize(l.direction.xyz, vec3(0.0, -1.0, 0.0)));
        float lo = l.cone.y;
        float hi = max(l.cone.x, lo + 1e-6);
        s.irradiance *= smoothstep(lo, hi, cos_theta);
    }
    return s;
}

LightSample sample_light(Light l, vec3 P) {
    return sample_light_near(l, P, 0.0);
}

#endif
