// The bricked layout of the voxel volumes (render::bricks, docs/SPARSE.md). A volume stores
// only resident bricks of 8^3 texels, side by side in a pool image; a map per pool (R32_UINT,
// one texel per brick of the grid) holds 0 for a brick that is not resident, else where its
// slot lies in the pool (brick_entry below). Pool 0 holds the full-resolution volumes; pools
// 1.. the directional levels larger than 64^3. Every volume that is sampled with hardware
// trilinear filtering (pool 0's radiance volumes, every directional level) stores each brick
// with a one-texel apron on its low side (9^3: texels 8b-1 .. 8b+7 of brick b per axis), so a
// filter stays inside one brick; a brick is resident when any of its 9^3 texels can be
// non-empty. Pool 0's integer volumes (albedo, normal, emission, flags, sums) share its slots
// without the apron (8^3 per slot).
// With grid.dims.z == 0 the volumes are dense and these helpers are the identity.
//
// The including shader declares, before including this file:
//   uniform GridBlock { VoxelGrid grid; };
//   layout(r32ui) uniform [readonly] uimage3D brick_maps[4];
// and defines BRICK_MAPS_WRITABLE where the maps are not readonly (the marking run and the
// allocation), for brick_mark and brick_map_store.
#ifndef DVSGI_BRICKS_GLSL
#define DVSGI_BRICKS_GLSL
#include "voxel.glsl"

// A map entry the mark pass set and the allocation has not yet replaced by a slot.
const uint BRICK_PENDING = 0xffffffffu;

bool bricked() {
    return grid.dims.z != 0u;
}

// Texels per side of pool p's level: the grid for pool 0, directional level p - 1 after.
int pool_level_side(int p) {
    int n = int(grid.dims.x);
    return p == 0 ? n : (n / 2) >> (p - 1);
}

// The raw map entry of brick b of pool p (0 outside the map). Literal image indices only.
uint brick_map_load(int p, ivec3 b) {
    if (any(lessThan(b, ivec3(0))) || any(greaterThanEqual(b, ivec3(int(grid.pools[p].w))))) return 0u;
    switch (p) {
        case 0: return imageLoad(brick_maps[0], b).r;
        case 1: return imageLoad(brick_maps[1], b).r;
        case 2: return imageLoad(brick_maps[2], b).r;
        default: return imageLoad(brick_maps[3], b).r;
    }
}

#ifdef BRICK_MAPS_WRITABLE
// Mark brick b of pool p pending unless it is resident or marked already.
void brick_mark(int p, ivec3 b) {
    switch (p) {
        case 0: imageAtomicCompSwap(brick_maps[0], b, 0u, BRICK_PENDING); break;
        case 1: imageAtomicCompSwap(brick_maps[1], b, 0u, BRICK_PENDING); break;
        case 2: imageAtomicCompSwap(brick_maps[2], b, 0u, BRICK_PENDING); break;
        default: imageAtomicCompSwap(brick_maps[3], b, 0u, BRICK_PENDING); break;
    }
}

void brick_map_store(int p, ivec3 b, uint v) {
    switch (p) {
        case 0: imageStore(brick_maps[0], b, uvec4(v)); break;
        case 1: imageStore(brick_maps[1], b, uvec4(v)); break;
        case 2: imageStore(brick_maps[2], b, uvec4(v)); break;
        default: imageStore(brick_maps[3], b, uvec4(v)); break;
    }
}
#endif

// A resident brick's map entry is where its slot lies in the pool image, in slots (10 bits
// per axis), with BRICK_RESIDENT set: a lookup finds the brick's texels with shifts and masks,
// not three divisions by the pool's sides per sample. 0: not resident.
const uint BRICK_RESIDENT = 1u << 30;

// The map entry of slot s (0-based, the allocation order) of pool p.
uint slot_entry(int p, uint s) {
    uvec4 q = grid.pools[p];
    return (s % q.x) | (((s / q.x) % q.y) << 10) | ((s / (q.x * q.y)) << 20) | BRICK_RESIDENT;
}

// The slot (0-based) of resident map entry e of pool p.
uint entry_slot(int p, uint e) {
    uvec4 q = grid.pools[p];
    return (e & 0x3ffu) + q.x * (((e >> 10) & 0x3ffu) + q.y * ((e >> 20) & 0x3ffu));
}

// Texel origin of resident map entry e's slot in an image of `stride`^3 texels per slot.
ivec3 entry_texel(uint e, int stride) {
    return ivec3(e & 0x3ffu, (e >> 10) & 0x3ffu, (e >> 20) & 0x3ffu) * stride;
}

// The map entry of brick b of pool p when it is resident; 0 when it is not.
uint brick_entry(int p, ivec3 b) {
    uint e = brick_map_load(p, b);
    return e == BRICK_PENDING ? 0u : e;
}

// Texel origin of slot s (0-based) in pool p's image.
ivec3 slot_texel(int p, uint s, int stride) {
    return entry_texel(slot_entry(p, s), stride);
}

// The pool texel of full-resolution voxel c in an integer volume (8^3 per slot); (-1) where c
// is outside the grid or its brick is not resident (it reads as empty).
ivec3 full_texel(ivec3 c) {
    if (any(lessThan(c, ivec3(0))) || any(greaterThanEqual(c, ivec3(int(grid.dims.x))))) return ivec3(-1);
    if (!bricked()) return c;
    uint e = brick_entry(0, c >> 3);
    return e == 0u ? ivec3(-1) : entry_texel(e, 8) + (c & 7);
}

// The pool texel of full-resolution voxel c in a radiance volume (9^3 per slot, the apron
// first); (-1) as full_texel.
ivec3 radiance_texel(ivec3 c) {
    if (any(lessThan(c, ivec3(0))) || any(greaterThanEqual(c, ivec3(int(grid.dims.x))))) return ivec3(-1);
    if (!bricked()) return c;
    uint e = brick_entry(0, c >> 3);
    return e == 0u ? ivec3(-1) : entry_texel(e, 9) + (c & 7) + 1;
}

// Store radiance v of full-resolution voxel c (inside the grid) in radiance volume `img`: its
// own brick's texel and, bricked, the copy in the apron of each resident brick above it on
// the axes where c is a brick's last texel. Every writer of a radiance volume stores through
// this, so the aprons always hold what their neighbours hold.
#define RADIANCE_STORE(img, c, v)                                                               \
    {                                                                                            \
        ivec3 c_ = (c);                                                                          \
        vec4 v_ = (v);                                                                           \
        if (!bricked()) {                                                                        \
            imageStore(img, c_, v_);                                                             \
        } else {                                                                                 \
            ivec3 lo_ = c_ >> 3, hi_ = (c_ + 1) >> 3;                                            \
            for (int z_ = lo_.z; z_ <= hi_.z; ++z_) {                                            \
                for (int y_ = lo_.y; y_ <= hi_.y; ++y_) {                                        \
                    for (int x_ = lo_.x; x_ <= hi_.x; ++x_) {                                    \
                        ivec3 b_ = ivec3(x_, y_, z_);                                            \
                        uint e_ = brick_entry(0, b_);                                            \
                        if (e_ != 0u) imageStore(img, entry_texel(e_, 9) + c_ - b_ * 8 + 1, v_); \
                    }                                                                            \
                }                                                                                \
            }                                                                                    \
        }                                                                                        \
    }

// The pool texel of texel t of pooled directional level p - 1 (its own brick's interior);
// (-1) outside the level or where the brick is not resident.
ivec3 level_texel(int p, ivec3 t) {
    if (any(lessThan(t, ivec3(0))) || any(greaterThanEqual(t, ivec3(pool_level_side(p))))) return ivec3(-1);
    uint e = brick_entry(p, t >> 3);
    return e == 0u ? ivec3(-1) : entry_texel(e, 9) + (t & 7) + 1;
}

// Pool coordinates (texels, continuous) of position `pos` (texels of the pool's level: the
// grid for pool 0, directional level pool - 1 after; in pool 0 the radiance volumes) for a
// trilinear lookup: the brick whose 9^3 texels hold both texels of the filter on each axis.
// w = 0 where that brick is not resident (all eight texels are empty).
vec4 level_lookup(int pool, vec3 pos) {
    ivec3 t0 = ivec3(floor(pos - 0.5));
    ivec3 b = (t0 + 1) >> 3;
    uint e = brick_entry(pool, b);
    if (e == 0u) return vec4(0.0);
    return vec4(vec3(entry_texel(e, 9)) + pos - vec3(b * 8) + 1.0, 1.0);
}

#endif
