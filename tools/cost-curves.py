#!/usr/bin/env python3
"""Per-pass cost curves: how each pass of a dvsgi frame grows with the voxel resolution, the
pixel count and the triangle count, with fitted exponents (cost ~ a * x^b, least squares on
log-log), from `bench` runs (one per point, the same flags for every point of a curve).

    tools/cost-curves.py --out DIR [--curves resolution,pixels,triangles]
        [--scene scenes/cornell-box.toml] [--resolutions 32,64,128,256]
        [--sizes 64,128,256,512] [--triangle-scenes A.toml,B.toml,...]
        [--frames 3] [--set KEY=VALUE ...] [--bench target/release/bench] [--reuse]

Pass times are the benchmark's serial host times (`--serial-profile`: each pass submitted
alone and waited for) on devices whose timestamps are not trusted (lavapipe), else the GPU
timestamps' medians. Writes each point's bench report (DIR/CURVE-X.json), DIR/curves.json
(the times and fits) and DIR/curves.md (one table per curve). Python 3 standard library only.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys


def run_bench(args, scene, extra, name, warmup=1):
    path = os.path.join(args.out, f"{name}.json")
    if args.reuse and os.path.exists(path):
        with open(path) as f:
            return json.load(f)
    cmd = [args.bench, "--scene", scene, "--modes", "sync", "--frames", str(args.frames), "--warmup", str(warmup),
           "--serial-profile", "--error-frames", "0", "--json", path]
    for s in args.set:
        cmd += ["--set", s]
    cmd += extra
    print("+", " ".join(cmd), file=sys.stderr, flush=True)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    with open(path) as f:
        return json.load(f)


def pass_times(report):
    """{pass name: ms} from the sync mode, serial host times unless timestamps are trusted."""
    trusted = report["device"]["timestamps_trusted"]
    mode = report["modes"][0]
    out = {}
    for p in mode["passes"]:
        stats = p["gpu_ms"] if trusted else p["serial_host_ms"]
        name = p["name"]
        if not stats and p["gpu_ms"]:
            # A pass of the first frame only (static voxelization): the serial profile runs
            # later frames, so only its timestamps exist.
            stats, name = p["gpu_ms"], name + " (timestamps)"
        if stats:
            out[name] = out.get(name, 0.0) + stats["median"]
    # Host wall clock per frame, first measured start to the GPU finishing the last (frames
    # in flight make the start-to-start median meaningless over a few frames).
    out["frame (host mean)"] = mode["frame_host_mean_ms"]
    return out


def fit(xs, ys):
    """Exponent b and factor a of y = a x^b (least squares in log-log), or None."""
    pts = [(math.log(x), math.log(y)) for x, y in zip(xs, ys) if x > 0 and y and y > 0]
    if len(pts) < 2:
        return None
    mx = sum(p[0] for p in pts) / len(pts)
    my = sum(p[1] for p in pts) / len(pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    if sxx == 0:
        return None
    b = sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx
    return {"exponent": b, "factor": math.exp(my - b * mx)}


def short(name):
    return re.sub(r"voxel bounce \([^)]*\)", "voxel bounce", name)


def curve(key, xs, points):
    """Table rows: pass -> times per point, exponent, growth between the last two points."""
    names = []
    for _, times in points:
        for n in times:
            if n not in names:
                names.append(n)
    rows = []
    for n in names:
        ys = [t.get(n) for _, t in points]
        f = fit(xs, ys)
        growth = ys[-1] / ys[-2] if len(ys) >= 2 and ys[-1] and ys[-2] else None
        rows.append({"pass": n, "ms": ys, "exponent": f and f["exponent"], "last_growth": growth})
    return {"curve": key, "x": xs, "rows": rows}


def markdown(c, label, device, command):
    head = f"### Cost against {label} ({device})\n\n`{command}`\n\n"
    cols = " | ".join(str(x) for x in c["x"])
    lines = [f"| pass | {cols} | exponent b (ms ~ x^b) | last step growth |",
             "|---" * (len(c["x"]) + 3) + "|"]
    for r in c["rows"]:
        ms = " | ".join("-" if v is None else (f"{v:.2f}" if v < 100 else f"{v:.0f}") for v in r["ms"])
        b = "-" if r["exponent"] is None else f"{r['exponent']:.2f}"
        g = "-" if r["last_growth"] is None else f"{r['last_growth']:.2f}×"
        lines.append(f"| {short(r['pass'])} | {ms} | {b} | {g} |")
    return head + "\n".join(lines) + "\n"


def triangles(args, scene):
    dvsgi = args.dvsgi or os.path.join(os.path.dirname(args.bench), "dvsgi")
    out = subprocess.run([dvsgi, "info", scene, "--set", "gi.mode=\"none\""], check=True, capture_output=True,
                         text=True).stdout
    m = re.search(r"(\d+) triangles", out)
    return int(m.group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--curves", default="resolution,pixels,triangles")
    ap.add_argument("--scene", default="scenes/cornell-box.toml")
    ap.add_argument("--resolutions", default="32,64,128,256")
    ap.add_argument("--sizes", default="64,128,256,512", help="square image sizes for the pixel curve")
    ap.add_argument("--size", type=int, default=64, help="image size of the resolution and triangle curves")
    ap.add_argument("--resolution", type=int, default=64, help="voxel resolution of the pixel and triangle curves")
    ap.add_argument("--triangle-scenes",
                    default="scenes/cornell-box.toml,scenes/cornell-sphere.toml,scenes/sponza.toml")
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--bench", default="target/release/bench")
    ap.add_argument("--dvsgi", help="the dvsgi binary (default: beside --bench), for triangle counts")
    ap.add_argument("--reuse", action="store_true", help="use a point's JSON already in DIR instead of running it")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    wanted = args.curves.split(",")
    result = {"curves": []}
    md = []
    device = None
    sets = "".join(f" --set {s}" for s in args.set)
    common = f"--modes sync --frames {args.frames} --warmup 1 --serial-profile --error-frames 0{sets}"
    size = ["--width", str(args.size), "--height", str(args.size)]
    if "resolution" in wanted:
        xs = [int(v) for v in args.resolutions.split(",")]
        points = []
        for n in xs:
            r = run_bench(args, args.scene, size + ["--set", f"gi.voxel_resolution={n}"], f"resolution-{n}")
            t = pass_times(r)
            occ = r["modes"][0].get("occupancy")
            if occ:
                t["occupied voxels (count)"] = occ["occupied"]
            points.append((n, t))
            device = r["device"]["name"]
        c = curve("resolution", xs, points)
        result["curves"].append(c)
        cmd = f"bench --scene {args.scene} --width {args.size} --height {args.size} {common} " \
              f"--set gi.voxel_resolution=N"
        md.append(markdown(c, "voxel resolution N", device, cmd))
    if "pixels" in wanted:
        sizes = [int(v) for v in args.sizes.split(",")]
        points = []
        for s in sizes:
            extra = ["--width", str(s), "--height", str(s), "--set", f"gi.voxel_resolution={args.resolution}"]
            r = run_bench(args, args.scene, extra, f"pixels-{s}")
            points.append((s * s, pass_times(r)))
            device = r["device"]["name"]
        c = curve("pixels", [s * s for s in sizes], points)
        result["curves"].append(c)
        cmd = f"bench --scene {args.scene} --width S --height S {common} --set gi.voxel_resolution={args.resolution}"
        md.append(markdown(c, "pixels (S² for S in " + args.sizes + ")", device, cmd))
    if "triangles" in wanted:
        scenes = args.triangle_scenes.split(",")
        points = []
        for i, sc in enumerate(scenes):
            extra = size + ["--set", f"gi.voxel_resolution={args.resolution}"]
            # No warm-up: the first frame's static voxelization is timed (by timestamps only).
            r = run_bench(args, sc, extra, f"triangles-{i}", warmup=0)
            points.append((triangles(args, sc), pass_times(r)))
            device = r["device"]["name"]
        points.sort(key=lambda p: p[0])
        c = curve("triangles", [p[0] for p in points], points)
        c["scenes"] = scenes
        result["curves"].append(c)
        cmd = f"bench --scene SCENE --width {args.size} --height {args.size} {common.replace('--warmup 1', '--warmup 0')} " \
              f"--set gi.voxel_resolution={args.resolution}"
        md.append(markdown(c, "triangles (" + ", ".join(scenes) + ")", device, cmd))
    with open(os.path.join(args.out, "curves.json"), "w") as f:
        json.dump(result, f, indent=1)
    with open(os.path.join(args.out, "curves.md"), "w") as f:
        f.write("\n".join(md))
    print("\n".join(md))


if __name__ == "__main__":
    main()
