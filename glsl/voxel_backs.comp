#version 460
// gi.plane_backs = "closed": which backs of the voxels that hold one plane close a solid. A
// cone starts on a surface, outside every solid, so the rays of a cone that reach the back of
// a closed surface (a block's far side, its top seen from under it) have met its front first:
// that back hides nothing the front has not, and the directional volumes' first level
// (aniso_mip.comp) leaves it out. Counted again, it made each closed object block a cone's
// partial footprint twice (ACCURACY.md, "Backs that close a solid"). The back of an open
// surface (a curtain, a single-sided wall, a floor seen from under it) stays in: a ray from
// behind meets it first.
//
// Bit `face` of a voxel's byte is set where the cones of directional volume `face` (+x, -x, +y,
// -y, +z, -z: those travelling along it meet its voxels' sides toward the other way) see its
// plane from behind and that back closes a solid. Looking from the voxel toward where those
// cones come from, past the rest of its own surface (a plane can fill two voxels along an
// axis), the first surface met must show its back too: the space between is inside both. Where
// the first surface shows its front (a floor under a block: the solid is closed by the floor,
// whose front faces into it), the space behind the voxel must be walled on the four other
// sides by surfaces that show it their backs, as a block's sides do. Anything else (nothing
// met, a front with the room beyond it, a surface seen edge-on, a voxel of several faces)
// leaves the back in: the rule never opens a surface a ray can meet first.
//
// Dispatched over the work list after each voxelization: the static voxels once, against the
// static geometry (a dynamic object can close no static solid it is not part of), and the
// dynamic ones after each revoxelization, against everything.
#include "common.glsl"
#include "voxel.glsl"

layout(local_size_x = 64) in;

// Over the list's dynamic range; else over every occupied voxel (after the static voxelization,
// the static ones).
layout(constant_id = 0) const bool DYNAMIC = false;

#define VOXEL_LIST_BINDING 0
#define VOXEL_LIST_QUALIFIER readonly
#include "voxel_list.glsl"
layout(set = 0, binding = 1) uniform GridBlock { VoxelGrid grid; };
layout(set = 0, binding = 2, r32ui) uniform readonly uimage3D brick_maps[4];
#include "bricks.glsl"
layout(set = 0, binding = 3, r32ui) uniform readonly uimage3D vox_albedo;
layout(set = 0, binding = 4, r32ui) uniform readonly uimage3D vox_normal;
layout(set = 0, binding = 5, r8ui) uniform writeonly uimage3D vox_backs;

// What voxel_plane returns for an empty voxel.
const vec3 EMPTY = vec3(2.0);

// The plane normal of the voxel stored at pool texel t (0 where it holds several faces), or
// EMPTY.
vec3 plane_at(ivec3 t) {
    if ((imageLoad(vox_albedo, t).r >> 24) == 0u) return EMPTY;
    vec3 n = unpack_rgb_count(imageLoad(vox_normal, t).r).rgb / 255.0 * 2.0 - 1.0;
    return plane_normal(n);
}

// The same for grid voxel u (EMPTY outside the grid and in bricks with nothing in them).
vec3 voxel_plane(ivec3 u) {
    ivec3 t = full_texel(u);
    return t.x < 0 ? EMPTY : plane_at(t);
}

// What a walk from voxel c toward side j meets first.
const int MEETS_NOTHING = 0;  // the grid's edge
const int MEETS_FRONT = 1;    // a surface facing c, seen edge-on, or a voxel of several faces
const int MEETS_BACK = 2;     // a surface whose back faces c
// A plane whose normal is within this cosine of the walk's right angle is seen edge-on (the
// normal volume holds 8 bits a channel: an axis-aligned plane's normal is off by up to 1/128).
const float EDGE_ON = 0.125;

int first_met(ivec3 c, int j) {
    ivec3 d = ivec3(side_axis(j));
    int axis = j / 2;
    int res = int(grid.dims.x);
    ivec3 u = c;
    // At most res steps (a brick with nothing in it is crossed in one).
    for (int k = 0; k < res; ++k) {
        u += d;
        if (u[axis] < 0 || u[axis] >= res) return MEETS_NOTHING;
        ivec3 t = full_texel(u);
        if (t.x < 0) {
            u[axis] = d[axis] > 0 ? (u[axis] | 7) : (u[axis] & ~7);
            continue;
        }
        vec3 p = plane_at(t);
        if (p == EMPTY) continue;
        return dot(p, vec3(d)) > EDGE_ON ? MEETS_BACK : MEETS_FRONT;
    }
    return MEETS_NOTHING;
}

// Whether the back of voxel c (plane normal n) that directional volume `face` sees closes a
// solid.
bool closes_a_solid(ivec3 c, vec3 n, int face) {
    int from = face ^ 1;  // the side the volume's cones come from
    ivec3 d = ivec3(side_axis(from));
    ivec3 last = c;
    for (int k = 0; k < 2; ++k) {
        vec3 p = voxel_plane(last + d);
        if (p == EMPTY || dot(p, n) < ONE_PLANE) break;
        last += d;
    }
    int along = first_met(last, from);
    if (along == MEETS_BACK) return true;
    // A front behind it: a pocket walled by backs on its four other sides, or nothing.
    ivec3 behind = last + d;
    if (along == MEETS_NOTHING || voxel_plane(behind) != EMPTY) return false;
    for (int j = 0; j < 6; ++j) {
        if (j / 2 != face / 2 && first_met(behind, j) != MEETS_BACK) return false;
    }
    return true;
}

void main() {
    uint i = list_invocation();
    uint count = DYNAMIC ? vlist.dynamic.count : vlist.occupied.count;
    if (i >= count) return;
    ivec3 c = unpack_voxel(vlist.entries[DYNAMIC ? vlist.static_count + i : i]);
    ivec3 t = full_texel(c);
    if (t.x < 0) return;
    vec3 n = plane_at(t);
    uint closed = 0u;
    if (n != EMPTY && n != vec3(0.0)) {
        for (int face = 0; face < 6; ++face) {
            if (front_share(n, face ^ 1) < 1.0 && closes_a_solid(c, n, face)) closed |= 1u << face;
        }
    }
    imageStore(vox_backs, t, uvec4(closed));
}
