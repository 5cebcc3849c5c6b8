#version 460
// One level of the six directional (anisotropic) radiance volumes. Each texel covers a 2x2x2
// block of the level below (the full-resolution radiance volume for level 0); for the
// volume of direction +x the block's front voxel along x is composited over its back voxel
// (premultiplied "over": c = c_front + (1 - a_front) c_back) for each of the four rows, and
// the four rows are averaged. Same for -x (front = high x), +y, -y, +z, -z. Texels are stored
// as (L * tau, tau) (voxel.glsl); the full-resolution volume holds (L, occupancy 0 or 1),
// which is premultiplied already.
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

// Level 0 reads the full-resolution volume (bound in every slot of `src`); higher levels
// read the previous level of each directional volume.
layout(constant_id = 0) const bool FROM_FULL = true;

layout(set = 0, binding = 0, rgba16f) uniform readonly image3D src[6];
layout(set = 0, binding = 1, rgba16f) uniform writeonly image3D dst[6];

vec4 over(vec4 front, vec4 back) {
    return front + (1.0 - clamp(front.a, 0.0, 1.0)) * back;
}

// Literal indices only: arrays of storage images are not indexed dynamically.
#define LOAD(FACE, C) (FROM_FULL ? imageLoad(src[0], C) : alpha_from_tau(imageLoad(src[FACE], C)))

#define INTEGRATE(FACE, AXIS, FRONT)                                              \
    {                                                                             \
        vec4 acc = vec4(0.0);                                                     \
        for (int u = 0; u < 2; ++u) {                                             \
            for (int v = 0; v < 2; ++v) {                                         \
                ivec3 o = AXIS == 0 ? ivec3(0, u, v) : (AXIS == 1 ? ivec3(u, 0, v) : ivec3(u, v, 0)); \
                ivec3 a = ivec3(0); a[AXIS] = 1;                                  \
                ivec3 front = base + o + a * FRONT;                               \
                ivec3 back = base + o + a * (1 - FRONT);                          \
                acc += over(LOAD(FACE, front), LOAD(FACE, back));                 \
            }                                                                     \
        }                                                                         \
        imageStore(dst[FACE], c, min(tau_from_alpha(acc * 0.25), vec4(HALF_MAX)));  \
    }

void main() {
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(c, imageSize(dst[0])))) return;
    ivec3 base = c * 2;
    INTEGRATE(0, 0, 0)  // +x: cones travelling +x meet low x first
    INTEGRATE(1, 0, 1)  // -x
    INTEGRATE(2, 1, 0)  // +y
    INTEGRATE(3, 1, 1)  // -y
    INTEGRATE(4, 2, 0)  // +z
    INTEGRATE(5, 2, 1)  // -z
}
