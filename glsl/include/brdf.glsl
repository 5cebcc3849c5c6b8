// The one BRDF of dvsgi: Lambert albedo/pi plus energy-normalised Blinn-Phong
// Ks (n+8)/(8 pi) (N.H)^n. Shared by every pass that shades.
#ifndef DVSGI_BRDF_GLSL
#define DVSGI_BRDF_GLSL
#include "common.glsl"

vec3 brdf_diffuse(vec3 albedo) {
    return albedo * INV_PI;
}

// N, V, L unit vectors; returns the specular BRDF value (1/sr).
vec3 brdf_specular(vec3 ks, float shininess, vec3 N, vec3 V, vec3 L) {
    if (max(ks.r, max(ks.g, ks.b)) <= 0.0) {
        return vec3(0.0);
    }
    vec3 H = safe_normalize(V + L, N);
    float n = max(shininess, 0.0);
    float ndoth = max(dot(N, H), 0.0);
    return ks * ((n + 8.0) / (8.0 * PI)) * pow(ndoth, n);
}

#endif
