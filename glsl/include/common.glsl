// Shared constants and the per-frame uniform block layout (mirrors render::FrameUniforms).
#ifndef DVSGI_COMMON_GLSL
#define DVSGI_COMMON_GLSL

const float PI = 3.14159265358979323846;
const float INV_PI = 0.31830988618379067154;

// Rec. 709 luminance of linear RGB (the auto exposure's average, the voxel light's side factors).
float luminance(vec3 c) {
    return dot(c, vec3(0.2126, 0.7152, 0.0722));
}

// Largest finite half float. Radiance in 16-bit targets is stored times the scene's radiance
// scale (FrameData.radiance_scale, VoxelGrid.params.y), which keeps it in range; the clamp to
// HALF_MAX is only a last guard.
const float HALF_MAX = 65504.0;

struct FrameData {
    mat4 view;
    mat4 proj;
    mat4 view_proj;
    mat4 inv_view_proj;
    vec4 camera_pos;   // xyz camera position, w scene time (s)
    uvec4 counts;      // x width, y height, z light count, w tone map (0 aces, 1 reinhard, 2 clamp)
    vec4 shadow;       // x PCF radius (texels), y normal bias (texels), z shadow map size, w exposure scale 2^EV
    vec4 radiance_scale;  // x: 16-bit radiance targets hold radiance * x (a power of two), y = 1/x
    uvec4 voxel;       // x voxel updates before this frame's, y this update's bounce interleave (1: all voxels),
                       // z frames in the rt reflections' history (0: none), w the frame's number
    vec4 exposure;     // x 1: "auto" (tonemap.comp adds exposure.comp's EV to shadow.w's), y how far the
                       // shown EV moves to this frame's (1: all the way; the viewer eases it)
    vec4 sky;          // x cos, y sin of the sky's turn about +y; z 1 with a sky (sky.glsl), w unused
};

// How far from 1 the length of a unit vector stored in three 16-bit floats can be (each
// component within 2^-11 of its value, relative: at most sqrt(3) 2^-11 = 0.00085).
const float HALF_NORMAL_ERROR = 0.001;

// Normalize, or `fallback` for a zero-length / non-finite vector.
vec3 safe_normalize(vec3 v, vec3 fallback) {
    float l2 = dot(v, v);
    return (l2 > 1e-30 && !isinf(l2)) ? v * inversesqrt(l2) : fallback;
}

// Octahedral encoding of a unit vector into [0, 1]^2 (two 8-bit G-buffer channels hold it to
// within about a degree), and its decoding.
vec2 oct_encode(vec3 n) {
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    vec2 e = n.z >= 0.0 ? n.xy : (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    return e * 0.5 + 0.5;
}

vec3 oct_decode(vec2 e) {
    e = e * 2.0 - 1.0;
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.xy -= vec2(n.x >= 0.0 ? t : -t, n.y >= 0.0 ? t : -t);
    return normalize(n);
}

// An orthonormal basis around unit n (Duff et al. 2017).
mat3 tangent_frame(vec3 n) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    vec3 bt = vec3(b, s + n.y * n.y * a, -n.y);
    return mat3(t, bt, n);
}

#endif
