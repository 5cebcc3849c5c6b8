// Scene tables (mirror render::scene_gpu::{GpuMaterial, GpuInstance}, std430).
#ifndef DVSGI_SCENE_GLSL
#define DVSGI_SCENE_GLSL

struct Material {
    vec4 albedo;     // rgb diffuse albedo (linear)
    vec4 specular;   // rgb Ks (linear), a Blinn-Phong exponent
    vec4 emission;   // rgb emitted radiance W/(sr m^2)
    ivec4 texture;   // x albedo texture index or -1
};

struct Instance {
    mat4 model;
    mat4 normal;     // inverse-transpose of the model matrix's 3x3
    uvec4 material;  // x material index
};

// A draw's triangles for ray queries (mirrors render::rays::RtDraw): a hit's instance custom
// index is its draw.
struct RtDraw {
    uint first_index;
    int vertex_offset;
    uint instance;
    uint pad;
};

#endif
