#!/usr/bin/env python3
"""Occupied voxels and bricks of an OBJ in a cubic grid, on the CPU: the same conservative
rule as dvsgi's voxelizer (every voxel a triangle touches, by the 13-axis separating-axis
test), for grids the GPU at hand cannot hold (`dvsgi info SCENE` reports the same figures
from the real voxelization where it fits; run both at a size that fits to check them).

    tools/occupancy.py OBJ --min X Y Z --max X Y Z --resolution N [N ...] [--bricks SHAPE ...]

The grid is the cube around [min, max] (a scene file's `[scene] bounds`), as dvsgi places it.
Prints occupied voxels and the occupied bricks of each SHAPE (default 4 8): a side (`8`) or
X x Y x Z voxels (`32x32x16`, a sparse image's page of 32-bit texels). A shape ending in `+`
also counts the bricks holding a voxel one step below an occupied one on any axis (what a
trilinear lookup between an empty brick and an occupied one reads). Needs numpy.
"""
import argparse
import numpy as np


def load_obj(path):
    verts, tris = [], []
    with open(path, encoding="latin-1") as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                verts.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                idx = [int(t.split("/")[0]) for t in p[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    tris.append([idx[0], idx[k], idx[k + 1]])
    return np.array(verts, dtype=np.float64), np.array(tris, dtype=np.int64)


def touched(t, res):
    """Flat indices of the voxels triangle t (3x3, voxel units) touches."""
    lo = np.maximum(np.floor(t.min(axis=0) - 1e-4).astype(int), 0)
    hi = np.minimum(np.floor(t.max(axis=0) + 1e-4).astype(int), res - 1)
    if np.any(hi < lo):
        return np.empty(0, dtype=np.int64)
    g = np.stack(np.meshgrid(*[np.arange(lo[i], hi[i] + 1) for i in range(3)], indexing="ij"), -1).reshape(-1, 3)
    c = g + 0.5
    v = t[None, :, :] - c[:, None, :]  # (n, 3 vertices, 3)
    e = [t[1] - t[0], t[2] - t[1], t[0] - t[2]]
    axes = [np.eye(3)[i] for i in range(3)] + [np.cross(e[0], e[1])]
    axes += [np.cross(ei, np.eye(3)[j]) for ei in e for j in range(3)]
    keep = np.ones(len(g), dtype=bool)
    for a in axes:
        l2 = a @ a
        if l2 < 1e-20:
            continue
        p = v @ a
        r = 0.5 * np.abs(a).sum()
        eps = 1e-5 * (r + 1e-3 * np.sqrt(l2))
        keep &= ~((p.min(axis=1) > r + eps) | (p.max(axis=1) < -r - eps))
    g = g[keep]
    return g[:, 0] + res * (g[:, 1] + res * g[:, 2])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("obj")
    ap.add_argument("--min", type=float, nargs=3, required=True)
    ap.add_argument("--max", type=float, nargs=3, required=True)
    ap.add_argument("--resolution", type=int, nargs="+", required=True)
    ap.add_argument("--bricks", nargs="+", default=["4", "8"])
    a = ap.parse_args()
    verts, tris = load_obj(a.obj)
    lo, hi = np.array(a.min), np.array(a.max)
    center, extent = (lo + hi) / 2, (hi - lo).max()
    origin = center - extent / 2
    print(f"{a.obj}: {len(tris)} triangles")
    for res in a.resolution:
        vs = extent / res
        w = (verts - origin) / vs
        occ = np.zeros(res ** 3, dtype=bool)
        for tri in tris:
            occ[touched(w[tri], res)] = True
        idx = np.nonzero(occ)[0]
        x, y, z = idx % res, (idx // res) % res, idx // (res * res)
        line = f"{res}^3: {len(idx)} occupied ({100 * len(idx) / res ** 3:.3f}%)"
        for shape in a.bricks:
            line += ", " + bricks(np.stack([x, y, z], -1), res, shape)
        print(line, flush=True)


def bricks(c, res, shape):
    """'K of M SHAPE bricks (P%)': the bricks of `shape` holding any of the voxels c."""
    dilate = shape.endswith("+")
    dims = [int(d) for d in shape.rstrip("+").split("x")]
    dims = np.array(dims * 3 if len(dims) == 1 else dims)
    if dilate:
        c = np.concatenate([c] + [np.maximum(c - np.eye(3, dtype=int)[i], 0) for i in range(3)])
    n = -(-res // dims)
    b = c // dims
    b = np.unique(b[:, 0] + n[0] * (b[:, 1] + n[1] * b[:, 2]))
    slots = int(np.prod(n))
    return f"{len(b)} of {slots} {shape} bricks ({100 * len(b) / slots:.2f}%)"


if __name__ == "__main__":
    main()
