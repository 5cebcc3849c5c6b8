// Shadow-map lookup with normal offset and PCF (mirrors render::lights::GpuShadowView).
// Every shadow view (directional: its cascades, then one over the whole scene; spot: 1;
// point: 6 cube faces +X,-X,+Y,-Y,+Z,-Z) is a layer of one depth array texture. A shader
// that looks views up defines SHADOW_VIEWS_BINDING before including this file.
#ifndef DVSGI_SHADOW_GLSL
#define DVSGI_SHADOW_GLSL
#include "lights.glsl"

struct ShadowView {
    mat4 view_proj;
    vec4 params;     // x world size of a texel (ortho) or per unit distance (perspective), y 1 = ortho
};

#ifdef SHADOW_VIEWS_BINDING
layout(set = 0, binding = SHADOW_VIEWS_BINDING, std430) readonly buffer ShadowViews { ShadowView views[]; };

// The view of a light that covers P. A directional light's views are its cascades, finest
// first, and last one over the whole scene (for voxels out of the camera's view): the first
// that holds P with a margin for the normal offset and the PCF footprint (`margin` texels of
// a `size`-texel map).
int shadow_view_index(Light l, vec3 P, float margin, float size) {
    if (uint(l.position.w) == LIGHT_DIRECTIONAL) {
        float inner = 1.0 - 2.0 * margin / size;
        for (int k = 0; k < l.shadow.y - 1; ++k) {
            vec4 c = views[l.shadow.x + k].view_proj * vec4(P, 1.0);
            vec3 ndc = c.xyz / c.w;
            if (all(lessThanEqual(abs(ndc.xy), vec2(inner))) && ndc.z >= 0.0 && ndc.z <= 1.0) {
                return l.shadow.x + k;
            }
        }
        return l.shadow.x + l.shadow.y - 1;
    }
    if (l.shadow.y == 6) {
        vec3 d = P - l.position.xyz;
        vec3 a = abs(d);
        int face;
        if (a.x >= a.y && a.x >= a.z) {
            face = d.x > 0.0 ? 0 : 1;
        } else if (a.y >= a.z) {
            face = d.y > 0.0 ? 2 : 3;
        } else {
            face = d.z > 0.0 ? 4 : 5;
        }
        return l.shadow.x + face;
    }
    return l.shadow.x;
}
#endif

// Fraction of the light reaching P (1 lit, 0 shadowed). `radius` PCF radius and
// `normal_bias` offset are in shadow-map texels; `size` is the map's side in texels.
//
// The bias against acne: the normal offset's distance d = texel * normal_bias * (0.5 + sin),
// more at grazing angles where acne appears, taken towards the light as d / cos rather than
// along the normal. For a planar receiver the two leave every PCF tap the same margin over the
// receiver's own depth (d / cos), but an offset along the normal also moves the lookup across
// the light by d sin, which shifted every shadow cast on the receiver by that much and detached
// it from its contact edges: the sunlit Sponza's direct light was 3.1% too bright, lit bands at
// the feet of walls and pillars (issue 26). An offset towards the light keeps the lookup where
// P is. It stays short of a point or spot light (half the distance to it).
float shadow_visibility(sampler2DArrayShadow map, ShadowView v, int layer, vec3 P, vec3 N, vec3 wi,
                        float dist, float radius, float normal_bias, float size) {
    float texel = v.params.y > 0.5 ? v.params.x : v.params.x * max(dist, 1e-6);
    float cos_l = clamp(dot(N, wi), 0.0, 1.0);
    float sin_l = sqrt(max(1.0 - cos_l * cos_l, 0.0));
    float d = texel * normal_bias * (0.5 + sin_l) / max(cos_l, 0.05);
    if (dist > 0.0) d = min(d, 0.5 * dist);
    vec3 Pb = P + wi * d;
    vec4 clip = v.view_proj * vec4(Pb, 1.0);
    if (clip.w <= 0.0) {
        return 1.0;
    }
    vec3 ndc = clip.xyz / clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || ndc.z > 1.0) {
        return 1.0;
    }
    float ref = ndc.z;
    if (radius <= 0.0) {
        return texture(map, vec4(uv, float(layer), ref));
    }
    // 4x4 bilinear compare taps spread over the radius (a 5x5-texel footprint at radius 1.5).
    float sum = 0.0;
    float step_uv = radius / (1.5 * size);
    for (int y = 0; y < 4; ++y) {
        for (int x = 0; x < 4; ++x) {
            vec2 o = (vec2(x, y) - 1.5) * step_uv;
            sum += texture(map, vec4(uv + o, float(layer), ref));
        }
    }
    return sum / 16.0;
}

#endif
