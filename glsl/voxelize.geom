#version 460
// Voxelization: project each triangle along its dominant axis onto a resolution^2 viewport and,
// without hardware conservative rasterization, dilate it so every pixel whose square the
// triangle touches gets a fragment (each edge moved out by the pixel half-box's support).
// The vertex attributes go to the fragments flat: a dilated (or conservatively rasterized)
// fragment's interpolated attributes would be the triangle's, stretched or extrapolated past
// its edges, so the fragment shader evaluates them on the triangle itself.
#include "common.glsl"
#include "voxel.glsl"

layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

layout(constant_id = 1) const bool DILATE = true;

layout(set = 0, binding = 4) uniform GridBlock { VoxelGrid grid; };

layout(location = 0) in vec3 v_world[];
layout(location = 1) in vec3 v_normal[];
layout(location = 2) in vec2 v_uv[];
layout(location = 3) flat in uint v_material[];

layout(location = 0) flat out vec3 g_normals[3];
layout(location = 3) flat out vec2 g_uvs[3];
layout(location = 6) flat out uint g_material;
layout(location = 7) flat out uint g_axis;
layout(location = 8) flat out vec3 g_t0;
layout(location = 9) flat out vec3 g_t1;
layout(location = 10) flat out vec3 g_t2;

float cross2(vec2 a, vec2 b) {
    return a.x * b.y - a.y * b.x;
}

void main() {
    vec3 p[3];
    for (int i = 0; i < 3; ++i) {
        p[i] = (v_world[i] - grid.origin.xyz) / grid.origin.w;
    }
    vec3 n = cross(p[1] - p[0], p[2] - p[0]);
    vec3 an = abs(n);
    float nmax = max(an.x, max(an.y, an.z));
    if (!(nmax > 1e-12)) {
        return;  // degenerate (or non-finite) triangle: covers no area
    }
    uint axis = (an.x >= an.y && an.x >= an.z) ? 0u : (an.y >= an.z ? 1u : 2u);
    vec2 q[3];
    for (int i = 0; i < 3; ++i) {
        q[i] = to_uvw(p[i], axis).xy;
    }
    vec2 outq[3] = q;
    if (DILATE) {
        float s = cross2(q[1] - q[0], q[2] - q[0]) >= 0.0 ? 1.0 : -1.0;
        vec2 en[3];
        float ec[3];
        for (int i = 0; i < 3; ++i) {
            vec2 e = q[(i + 1) % 3] - q[i];
            en[i] = s * vec2(e.y, -e.x);  // outward normal (unnormalized)
            ec[i] = dot(en[i], q[i]) + 0.5 * (abs(en[i].x) + abs(en[i].y));
        }
        for (int i = 0; i < 3; ++i) {
            int a = (i + 2) % 3;  // edge ending at vertex i
            int b = i;            // edge starting at vertex i
            float det = cross2(en[a], en[b]);
            if (abs(det) > 1e-20) {
                outq[i] = vec2(ec[a] * en[b].y - ec[b] * en[a].y, en[a].x * ec[b] - en[b].x * ec[a]) / det;
            }
        }
    }
    float res = float(grid.dims.x);
    for (int i = 0; i < 3; ++i) {
        gl_Position = vec4(outq[i] / res * 2.0 - 1.0, 0.5, 1.0);
        g_normals = v_normal;
        g_uvs = v_uv;
        g_material = v_material[i];
        g_axis = axis;
        g_t0 = p[0];
        g_t1 = p[1];
        g_t2 = p[2];
        EmitVertex();
    }
    EndPrimitive();
}
