#!/usr/bin/env python3
"""Writes scenes/leak/: the scenes of ACCURACY.md's leak tests (issue 44), made of boxes.

A room 4 m x 3 m x 4 m inside (x 0..4, y 0..3, z 0..4) under a sun and a sky, its walls,
floor and roof slabs of a thickness given in voxels of the default 128^3 grid. Every scene
sets `[scene] bounds` to a 5.12 m cube, so one voxel is exactly 4 cm at 128^3 (8 cm at 64^3,
2 cm at 256^3) and a wall's thickness in voxels is known.

  sealed-room-tN   closed on every side, walls N voxels (N = 1, 2, 4) thick: no light inside
  open-room-tN     the same without its roof: what the sealed room's leak is measured against
  window-room      2-voxel walls, a 1.2 m x 1 m window in the +x wall, sun and sky through it
  thin-wall        two rooms side by side, sharing a 1-voxel wall; the +x room has no roof
  corner           a floor and one wall, lit by the sun: the corner where a floor meets a lit wall

Run from the repository root: python3 tools/make-leak-scenes.py
"""

import os

VOXEL = 0.04  # at 128^3 over the 5.12 m bounds
INSIDE = (4.0, 3.0, 4.0)
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "leak")

SUN = """
[[lights]]
type = "directional"
name = "sun"
direction = [-0.45, -0.8, -0.35]
irradiance = [6.0, 5.6, 5.0]   # W/m^2 on a surface facing the sun
"""

SKY = """
[sky]
type = "gradient"
zenith = [0.35, 0.5, 0.9]      # W/(sr m^2)
horizon = [0.8, 0.85, 0.9]
ground = [0.25, 0.22, 0.2]
"""


def box(lo, hi):
    """The six faces of an axis-aligned box as quads (counter-clockwise seen from outside)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return [
        ((x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)),  # +x
        ((x0, y0, z1), (x0, y1, z1), (x0, y1, z0), (x0, y0, z0)),  # -x
        ((x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)),  # +y
        ((x0, y0, z1), (x0, y0, z0), (x1, y0, z0), (x1, y0, z1)),  # -y
        ((x1, y0, z1), (x1, y1, z1), (x0, y1, z1), (x0, y0, z1)),  # +z
        ((x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)),  # -z
    ]


def write_obj(name, groups):
    """groups: [(group name, [box (lo, hi)])]."""
    lines = [f"# {name}: written by tools/make-leak-scenes.py (boxes, metres)."]
    n = 0
    for group, boxes in groups:
        lines.append(f"g {group}")
        for lo, hi in boxes:
            for quad in box(lo, hi):
                for v in quad:
                    lines.append("v %.4f %.4f %.4f" % v)
                lines.append(f"f {n + 1} {n + 2} {n + 3} {n + 4}")
                n += 4
    with open(os.path.join(OUT, name + ".obj"), "w") as f:
        f.write("\n".join(lines) + "\n")


def room(t, roof=True, window=None, x_offset=0.0, width=INSIDE[0]):
    """The slabs of a room of wall thickness t (metres) whose inside starts at x = x_offset and
    is `width` wide. window: (z0, z1, y0, y1) hole in the +x wall."""
    _, h, d = INSIDE
    w = width
    x0, x1 = x_offset, x_offset + w
    groups = [
        ("floor", [((x0 - t, -t, -t), (x1 + t, 0.0, d + t))]),
        ("wall_nx", [((x0 - t, 0.0, -t), (x0, h, d + t))]),
        ("wall_nz", [((x0, 0.0, -t), (x1, h, 0.0))]),
        ("wall_pz", [((x0, 0.0, d), (x1, h, d + t))]),
    ]
    if window is None:
        groups.append(("wall_px", [((x1, 0.0, -t), (x1 + t, h, d + t))]))
    else:
        z0, z1, y0, y1 = window
        groups.append(
            (
                "wall_px",
                [
                    ((x1, 0.0, -t), (x1 + t, h, z0)),
                    ((x1, 0.0, z1), (x1 + t, h, d + t)),
                    ((x1, 0.0, z0), (x1 + t, y0, z1)),
                    ((x1, y1, z0), (x1 + t, h, z1)),
                ],
            )
        )
    if roof:
        groups.append(("roof", [((x0 - t, h, -t), (x1 + t, h + t, d + t))]))
    return groups


def scene_toml(name, title, obj, camera, bounds_centre, notes, sky=True, sun=True):
    c = bounds_centre
    half = 2.56
    lo = [round(c[i] - half, 4) for i in range(3)]
    hi = [round(c[i] + half, 4) for i in range(3)]
    text = f"""# {title}
# Written by tools/make-leak-scenes.py. {notes}
# The bounds make one voxel 4 cm at 128^3 (ACCURACY.md, "Sky light and leaks").

[scene]
name = "{title}"
bounds = {{ min = {lo}, max = {hi} }}

[camera]
position = {camera[0]}
target = {camera[1]}
fov_y = 75.0
near = 0.01

[render]
width = 64
height = 64

[[materials]]
name = "plaster"
albedo = [0.7, 0.7, 0.7]

[[objects]]
obj = "{obj}.obj"
material = "plaster"
"""
    if sun:
        text += SUN
    if sky:
        text += SKY
    with open(os.path.join(OUT, name + ".toml"), "w") as f:
        f.write(text)


def main():
    os.makedirs(OUT, exist_ok=True)
    inside_camera = ([0.4, 1.6, 0.4], [3.2, 0.8, 3.4])
    centre = (2.0, 1.5, 2.0)
    for n in (1, 2, 4):
        t = n * VOXEL
        write_obj(f"sealed-room-t{n}", room(t))
        write_obj(f"open-room-t{n}", room(t, roof=False))
        scene_toml(
            f"sealed-room-t{n}",
            f"Sealed room, walls {n} voxel{'s' if n > 1 else ''} thick",
            f"sealed-room-t{n}",
            inside_camera,
            centre,
            "Closed on every side: the path tracer finds no light inside.",
        )
        scene_toml(
            f"open-room-t{n}",
            f"Open room, walls {n} voxel{'s' if n > 1 else ''} thick, no roof",
            f"open-room-t{n}",
            inside_camera,
            centre,
            "The sealed room without its roof: what its leak is measured against.",
        )
    write_obj("window-room", room(2 * VOXEL, window=(1.4, 2.6, 0.9, 1.9)))
    scene_toml(
        "window-room",
        "Room with a window",
        "window-room",
        ([0.4, 1.6, 3.6], [3.4, 0.9, 1.0]),
        centre,
        "2-voxel walls, a 1.2 m x 1 m window in the +x wall; the sun shines in through it.",
    )
    # Two rooms 2.4 m wide sharing the wall at x = 2.4..2.44 (1 voxel): the -x room closed, the
    # +x room open.
    t = VOXEL
    lit = room(t, roof=False, x_offset=2.4 + t, width=2.4)
    dark = room(t, width=2.4)
    groups = [(f"dark_{g}", b) for g, b in dark if g != "wall_px"] + [("shared_wall", dict(dark)["wall_px"])]
    groups += [(f"lit_{g}", b) for g, b in lit if g != "wall_nx"]
    write_obj("thin-wall", groups)
    scene_toml(
        "thin-wall",
        "Thin wall between a lit and an unlit room",
        "thin-wall",
        ([0.3, 1.6, 0.4], [2.3, 1.0, 3.0]),
        (2.42, 1.5, 2.0),
        "The camera is in the closed -x room; the +x room, open to the sky, shares its 1-voxel wall.",
    )
    write_obj(
        "corner",
        [("floor", [((-1.0, -2 * VOXEL, -1.0), (4.0, 0.0, 4.0))]), ("wall", [((-1.0, 0.0, 4.0), (4.0, 3.0, 4.0 + 2 * VOXEL))])],
    )
    corner_sun = SUN.replace("[-0.45, -0.8, -0.35]", "[0.3, -0.6, 0.75]")
    text_path = os.path.join(OUT, "corner.toml")
    scene_toml(
        "corner",
        "A floor meeting a lit wall",
        "corner",
        ([1.5, 1.4, 0.2], [1.5, 0.5, 4.0]),
        (1.5, 1.5, 1.54),
        "The sun lights the wall and the floor in front of it; no sky: the corner's bounce alone.",
        sky=False,
        sun=False,
    )
    with open(text_path, "a") as f:
        f.write(corner_sun)


if __name__ == "__main__":
    main()
