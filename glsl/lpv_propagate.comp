#version 460
// One light propagation step (Kaplanyan & Dachsbacher 2010; CPU reference render::lpv::
// propagate_step): each cell gathers from its six neighbours the flux I(dir) dOmega that the
// neighbour's light sends through each of the five faces of this cell it can see (the face
// straight ahead and the four sides), each face re-emitted as a clamped-cosine lobe along its
// normal. Fluxes stay negative where the two-band lobe is (dropping them would add light:
// radiance is clamped at the lookup). From the second step on, the
// geometry volume halfway between the cells blocks a fraction of each flux (fuzzy occlusion).
// The result is written for the next step and added to the running sum (from the step that
// grid.dims.z asks for on: light that has travelled at least that many cells).
#include "common.glsl"
#include "sh.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(set = 0, binding = 0) uniform GridBlock { LpvGrid grid; };
layout(set = 0, binding = 1, rgba32f) uniform readonly image3D src_r;
layout(set = 0, binding = 2, rgba32f) uniform readonly image3D src_g;
layout(set = 0, binding = 3, rgba32f) uniform readonly image3D src_b;
layout(set = 0, binding = 4, rgba32f) uniform readonly image3D geometry;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image3D dst_r;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image3D dst_g;
layout(set = 0, binding = 7, rgba32f) uniform writeonly image3D dst_b;
layout(set = 0, binding = 8, rgba32f) uniform image3D sum_r;
layout(set = 0, binding = 9, rgba32f) uniform image3D sum_g;
layout(set = 0, binding = 10, rgba32f) uniform image3D sum_b;

layout(push_constant) uniform Push { uint step; } pc;

const float DIRECT_FACE = 0.4006697 / PI;
const float SIDE_FACE = 0.4234413 / PI;
const ivec3 AXES[6] = ivec3[6](ivec3(1, 0, 0), ivec3(-1, 0, 0), ivec3(0, 1, 0), ivec3(0, -1, 0),
                               ivec3(0, 0, 1), ivec3(0, 0, -1));

// Flux through one face along `eval`, re-emitted along `face`, for the three colours.
void face_flux(vec4 r, vec4 g, vec4 b, vec4 block, vec3 eval, vec3 face, float angle, inout vec4 o[3]) {
    vec4 y = sh_eval(eval);
    float pass_through = 1.0 - clamp(dot(block, y), 0.0, 1.0);
    vec4 lobe = cos_lobe(face) * (angle * pass_through);
    o[0] += dot(r, y) * lobe;
    o[1] += dot(g, y) * lobe;
    o[2] += dot(b, y) * lobe;
}

void main() {
    int res = int(grid.dims.x);
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(c, ivec3(res)))) return;
    bool occlude = grid.dims.y != 0u && pc.step > 0u;
    vec4 o[3] = vec4[3](vec4(0.0), vec4(0.0), vec4(0.0));
    for (int i = 0; i < 6; ++i) {
        ivec3 d = AXES[i];
        ivec3 from = c - d;
        if (any(lessThan(from, ivec3(0))) || any(greaterThanEqual(from, ivec3(res)))) continue;
        vec4 r = imageLoad(src_r, from), g = imageLoad(src_g, from), b = imageLoad(src_b, from);
        vec4 block = occlude ? 0.5 * (imageLoad(geometry, from) + imageLoad(geometry, c)) : vec4(0.0);
        vec3 main_dir = vec3(d);
        face_flux(r, g, b, block, main_dir, main_dir, DIRECT_FACE, o);
        for (int j = 0; j < 6; ++j) {
            ivec3 side = AXES[j];
            if (dot(side, d) != 0) continue;
            vec3 eval = normalize(main_dir + 0.5 * vec3(side));
            face_flux(r, g, b, block, eval, vec3(side), SIDE_FACE, o);
        }
    }
    imageStore(dst_r, c, o[0]);
    imageStore(dst_g, c, o[1]);
    imageStore(dst_b, c, o[2]);
    if (pc.step + 1u >= grid.dims.z) {
        imageStore(sum_r, c, imageLoad(sum_r, c) + o[0]);
        imageStore(sum_g, c, imageLoad(sum_g, c) + o[1]);
        imageStore(sum_b, c, imageLoad(sum_b, c) + o[2]);
    }
}
