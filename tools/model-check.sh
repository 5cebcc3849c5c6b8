#!/usr/bin/env bash
# The schedule model (`bench --model`) against every bench report of one device: each report's
# scene, scenario, settings and frames in flight are recorded here on the split device
# (tools/with-split-queues.sh: a dedicated compute-only family, as on NVIDIA GPUs), simulated
# with the report's pass times, and compared with what the report measured.
#
#   tools/model-check.sh [REPORT_DIR [OUT_DIR]]     (default docs/bench/nvidia-h200, OUT_DIR/model)
#
# A report measured by an older version may have run passes this version skips (before the
# shadow maps were cached, a static scene redrew them every frame). The model then warns that
# the recorded frame is not the measured one; for a static report this script records again
# in the redraw scenario (every map redrawn, the voxels updated every frame) and keeps that
# recording if its frame is the measured one. The summary says which recording was used.
# Environment: BENCH (default target/release/bench), FRAMES (timed frames recorded, default 8:
# the simulated frames repeat, so a few suffice).
set -euo pipefail
cd "$(dirname "$0")/.."
dir="${1:-docs/bench/nvidia-h200}"
out="${2:-$dir/model}"
bench="${BENCH:-target/release/bench}"
frames="${FRAMES:-8}"
mkdir -p "$out"
mismatch() { grep -q "is not the one the report measured" "$1"; }
for r in "$dir"/bench-*.json "$dir"/serial-*.json; do
  [ -f "$r" ] || continue
  name="$(basename "$r" .json)"
  echo "model-check: $name" >&2
  args=(--model "$r" --frames "$frames" --json "$out/$name.json")
  if ! tools/with-split-queues.sh "$bench" "${args[@]}" > "$out/$name.txt" 2> "$out/$name.log"; then
    echo "model-check: $name failed; see $out/$name.log" >&2
    continue
  fi
  if mismatch "$out/$name.txt" && grep -q '"scenario": "static"' "$r"; then
    # Keep the report's own scenario (and its warning) unless the redraw one is the measured frame.
    if tools/with-split-queues.sh "$bench" --model "$r" --frames "$frames" --scenario redraw \
      --json "$out/$name.redraw.json" > "$out/$name.redraw.txt" 2>> "$out/$name.log" &&
      ! mismatch "$out/$name.redraw.txt"; then
      mv "$out/$name.redraw.txt" "$out/$name.txt"
      mv "$out/$name.redraw.json" "$out/$name.json"
      sed -i "s|$name.redraw.json|$name.json|" "$out/$name.txt"
    else
      rm -f "$out/$name.redraw.txt" "$out/$name.redraw.json"
    fi
  fi
done
python3 - "$out" <<'PY'
import glob, json, os, sys
out = sys.argv[1]
rows, worst = [], 0.0
for f in sorted(glob.glob(os.path.join(out, "*.json"))):
    r = json.load(open(f))
    name = os.path.basename(f)[:-5]
    for m in r["modes"]:
        if m["measured_frame_host_ms"] is None:
            continue
        e = 100 * m["error"]
        worst = max(worst, abs(e))
        same = "yes" if not m["structure_differences"] else "NO: " + "; ".join(m["structure_differences"])
        rows.append(f'{name:<44} {r["scenario"]:<8} {m["mode"]:<13} {m["measured_frame_host_ms"]:8.2f} '
                    f'{m["predicted"]["frame_host_ms"]["median"]:8.2f} {e:+6.1f}%  {same}')
print(f'{"report":<44} {"recorded":<8} {"mode":<13} {"measured":>8} {"modelled":>8} {"error":>7}  same frame')
print("\n".join(rows))
print(f"{len(rows)} measured modes; largest error {worst:.1f}%")
PY
