#!/usr/bin/env bash
# One command that measures dvsgi on a GPU and writes everything under OUT_DIR, named by the
# device, ready to commit to docs/bench/:
#
#   tools/gpu-report.sh [--bundle DIR] [--only GROUPS] OUT_DIR
#
# GROUPS (comma-separated; default all): info, tests, bench, model, layouts, techniques,
# reflections, serial, raster, sweep, accuracy, cones, footprints, backs, curves.
# Runs into an existing OUT_DIR add to it (steps.tsv appends), so a report can be split across
# several shorter sessions on the GPU machine; README.md is rewritten from all of OUT_DIR.
#
#   info.txt               dvsgi info (devices, queue families, topology, limits) + per-scene costs
#   tests.log              the test suite, validation on (any validation message fails a test)
#   bench-*.json/.svg/.txt bench, static and dynamic, Cornell box and Sponza, 1920x1080,
#                          128^3 and 256^3 voxels, sync / async / async-lagged / async-pipelined
#                          (JSON, timeline, table);
#                          bench-{cornell,sponza}-{rsm,lpv,rsm-lpv}: the other techniques, every
#                          frame redrawn (--scenario redraw: their maps and volume as if the light moved)
#   model-*.json/.txt      the schedule model (issue 40, bench --model): each bench-* run of the
#                          bench group predicted from its own pass times and the submits recorded
#                          here, beside what it measured
#   bench-layout-*         the voxel layouts (issue 27): Sponza at 128^3, 256^3 and 512^3, bricks
#                          and dense, sync, 1920x1080; info-layouts.txt: their memory
#   bench-reflect-*       the reflections (issue 28): the mirror and glossy Cornell boxes with the
#                          specular cone and with ray-traced reflections (gi.specular = "rt"),
#                          sync and async; a device without ray queries records the refusal;
#                          bench-shadows-{cornell-box,crytek-sponza}-{shadow-map,rt}: the direct light's
#                          shadow maps against shadow rays (gi.shadows = "rt"), sync and async
#   sweep-cornell/         a short speed/accuracy sweep against the path-traced reference, with
#                          rows for rsm, lpv and rsm+lpv on the same frontier
#   serial-*.json/.txt     the serial profile (every pass submitted alone and host-timed)
#   raster-*.json/.txt     the G-buffer's time split (issue 41, bench --raster-profile): the pass, a
#                          depth prepass of its opaque draws, the G-buffer over that depth, with the
#                          shader invocations and overdraw; Sponza and Crytek's Sponza, direct light;
#                          bench-prepass-sponza-{on,off}: the whole frame (all four schedules,
#                          ${res[0]}^3) with render.depth_prepass forced on and off
#   accuracy-sponza/       Dabrovic's Sponza at 128^3, 256^3 and 512^3, dense and bricks, against a
#                          4096-spp reference, whole image and by region (compare --scene --ref-direct)
#   cones-{cornell,sponza}/ the cone set and the cone filter (issue 43): 9 and 16 cones, trilinear
#                          and two-tap, 128^3 and 256^3, against a 4096-spp reference at 480x270,
#                          whole image (sweep-*: timed, one frontier per filter) and by region
#                          (v*-c*-*.json: compare --scene --ref-direct --test-indirect);
#                          bench-cones-sponza-*: each of the four at 1920x1080, sync, 128^3
#   bench-footprint-sponza-{static,redraw}-{ultra,max,max-bounce}: the top presets' frame
#                          (issue 43), Sponza, 1920x1080, sync, static (the pixels' cones) and
#                          redraw (with the voxel light and bounce): `ultra` (the defaults), `max`
#                          (the pixels' cones in quadrants) and `max` with gi.bounce_footprint =
#                          "quadrants" (the bounce's too)
#   backs-sponza/          gi.plane_backs = "closed" (issue 43, fifteenth part): Dabrovic's Sponza at
#                          128^3, 256^3 and 512^3 against a 4096-spp reference at 480x270, by region
#                          (v*-closed.json); bench-backs-sponza-v*-{lit,closed}: 1920x1080, sync,
#                          from the first frame (--warmup 0: the pass that marks the static voxels)
#   curves/                per-pass cost against voxel resolution, pixels and triangles, with
#                          fitted exponents (tools/cost-curves.py; curves.md is the table)
#   steps.tsv, report.log  each step's exit status and seconds; README.md summarises
#
# Headless: no display, no window system. On a machine with only the NVIDIA driver (no Rust,
# no Vulkan loader, no validation layer), make a bundle where the code is built
# (tools/gpu-bundle.sh .gpu), carry .gpu, and pass --bundle .gpu: the script unpacks the
# binaries, test executables, scenes, and the loader and validation layer packages (as root).
# Without --bundle it uses target/release (building with cargo when it can).
#
# Every step has a time limit (the whole report fits in 25 minutes on one GPU); a failed step
# is recorded and the next one runs. DVSGI_REPORT_QUICK=1 shrinks every size for a dry run
# on lavapipe. Exit status: 0 when every step passed.
set -uo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bundle=""
only=""
while [ $# -gt 1 ]; do
  case "$1" in
    --bundle) bundle="${2:?--bundle needs a directory}" ;;
    --only) only="${2:?--only needs a list of groups}" ;;
    *) break ;;
  esac
  shift 2
done
if [ $# -ne 1 ]; then
  echo "usage: tools/gpu-report.sh [--bundle DIR] [--only GROUPS] OUT_DIR" >&2
  exit 2
fi
for g in ${only//,/ }; do
  case "$g" in
    info | tests | bench | model | layouts | techniques | reflections | serial | raster | sweep | accuracy | cones | footprints | backs | curves) ;;
    *) echo "gpu-report: unknown group '$g' (info, tests, bench, model, layouts, techniques, reflections, serial, raster, sweep, accuracy, cones, footprints, backs, curves)" >&2; exit 2 ;;
  esac
done
# want GROUP: whether this run measures GROUP.
want() { [ -z "$only" ] || [[ ",$only," == *",$1,"* ]]; }
mkdir -p "$1" || exit 1
out="$(cd "$1" && pwd)"
cd "$root"
quick="${DVSGI_REPORT_QUICK:-0}"
bin="$root/target/release"
tests_dir=""

log() { echo "[gpu-report $(date -u +%H:%M:%S)] $*" | tee -a "$out/report.log" >&2; }
[ -s "$out/steps.tsv" ] || printf 'step\tstatus\tseconds\n' >"$out/steps.tsv"
failed=0
# step NAME SECONDS CMD...: run with a time limit, log, record status; never stops the report.
step() {
  local name=$1 limit=$2
  shift 2
  log "$name: $*"
  local t0=$SECONDS
  timeout --kill-after=10 "$limit" "$@"
  local rc=$?
  printf '%s\t%s\t%s\n' "$name" "$rc" "$((SECONDS - t0))" >>"$out/steps.tsv"
  if [ $rc -ne 0 ]; then
    failed=$((failed + 1))
    log "$name: FAILED (exit $rc$([ $rc -eq 124 ] && echo ", over its ${limit} s limit"))"
  fi
  return 0
}

# have_scene NAME: whether scenes/NAME.toml's assets are here. A bundle leaves Crytek's Sponza
# out (70 MB of textures, over what a GPU machine's carry takes): its steps are recorded as
# skipped ("skip" in steps.tsv), not failed.
have_scene() {
  case "$1" in
    crytek-sponza) [ -f "$root/../shared/scenes/crytek-sponza/sponza.obj" ] ;;
    *) true ;;
  esac
}
skip() {
  log "$1: skipped ($2)"
  printf '%s\tskip\t0\n' "$1" >>"$out/steps.tsv"
}

unpack_bundle() {
  local b
  b="$(cd "$bundle" && pwd)/bundle.tar.xz"
  [ -f "$b" ] || { log "no $b: make it with tools/gpu-bundle.sh"; exit 1; }
  local u="$root/target/gpu-bundle"
  rm -rf "$u" && mkdir -p "$u" && tar -C "$u" -xJf "$b" || exit 1
  if [ "$(id -u)" -eq 0 ]; then
    for f in "$u"/debs/*.deb; do dpkg -x "$f" /; done
    ldconfig
  else
    log "not root: the loader and validation layer packages in $u/debs are not installed"
  fi
  bin="$u/bin"
  tests_dir="$u/tests"
  # Test executables find the repository (and the dvsgi binary) by the path they were built in.
  local built
  built="$(cat "$u/manifest-dir")"
  if [ "$built" != "$root" ] && [ ! -e "$built" ]; then
    mkdir -p "$(dirname "$built")" && ln -s "$root" "$built"
  fi
  mkdir -p "$root/target/release"
  for b in dvsgi bench soak; do [ -e "$root/target/release/$b" ] || cp "$u/bin/$b" "$root/target/release/$b"; done
  # Scene files look for assets in ../shared/scenes beside the repository.
  if [ ! -e "$root/../shared/scenes" ]; then
    mkdir -p "$root/../shared" && ln -s "$u/shared/scenes" "$root/../shared/scenes"
  fi
  cp "$u/commit" "$out/commit.txt"
}

if [ -n "$bundle" ]; then
  unpack_bundle
elif [ ! -x "$bin/dvsgi" ] || [ ! -x "$bin/bench" ]; then
  command -v cargo >/dev/null || { log "no $bin/dvsgi and no cargo: use --bundle (tools/gpu-bundle.sh)"; exit 1; }
  cargo build --release --locked --bins || exit 1
fi
[ -f "$out/commit.txt" ] || git rev-parse HEAD >"$out/commit.txt" 2>/dev/null || true
# The NVIDIA driver's ICD where the loader may not look by itself.
nv_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ] && [ -f "$nv_icd" ]; then
  export VK_DRIVER_FILES="$nv_icd"
fi

# ----- 1. The device. -----
if want info || [ ! -s "$out/info.txt" ]; then
  step info 60 "$bin/dvsgi" info >"$out/info.txt" 2>&1
fi
device="$(sed -n 's/^chosen device: \[[0-9]*\] //p' "$out/info.txt" | head -1)"
device="${device:-unknown device}"
log "device: $device"
echo "$device" >"$out/DEVICE"
command -v nvidia-smi >/dev/null && nvidia-smi >"$out/nvidia-smi.txt" 2>&1
if want info; then
  for s in cornell-box sponza; do
    for v in 128 256; do
      step "info-$s-v$v" 120 "$bin/dvsgi" info "scenes/$s.toml" --set "gi.voxel_resolution=$v" \
        >>"$out/info.txt" 2>&1
    done
  done
fi

# ----- 2. The test suite, validation on. -----
run_tests() {
  if [ -n "$tests_dir" ]; then
    local rc=0 t
    for t in "$tests_dir"/*; do
      echo "=== $(basename "$t")"
      # The bundle carries no Crytek Sponza (70 MiB, over what travels to a GPU machine), which
      # this one test loads with every other shipped scene.
      local skip=()
      [ "$(basename "$t")" = unit ] && skip=(--skip scene::tests::every_shipped_scene_loads)
      DVSGI_VALIDATION=1 "$t" "${skip[@]}" || rc=1
    done
    return $rc
  fi
  command -v cargo >/dev/null || { echo "no test executables (use --bundle) and no cargo"; return 1; }
  local args=(--release --locked --lib) f
  for f in tests/*.rs; do
    f="$(basename "$f" .rs)"
    [ "$f" = split_queues ] || args+=(--test "$f") # the layer splits one-queue CPU devices only
  done
  DVSGI_VALIDATION=1 cargo test "${args[@]}"
}
if [ "$quick" = 1 ]; then
  log "tests: skipped (DVSGI_REPORT_QUICK=1)"
elif want tests && [ -n "$tests_dir" ] && [ -z "$(ls -A "$tests_dir")" ]; then
  skip tests "the bundle has no test executables (tools/gpu-bundle.sh --no-tests)"
elif want tests; then
  # `timeout` runs programs, not shell functions: the function goes along in a child bash.
  export tests_dir
  step tests 900 bash -c "$(declare -f run_tests); run_tests" >"$out/tests.log" 2>&1
fi

# ----- 3. Bench: static and dynamic, Cornell box and Sponza, 128^3 and 256^3, all modes. -----
if [ "$quick" = 1 ]; then
  w=64 h=36 res=(16 32) frames=2 warmup=1
else
  w=1920 h=1080 res=(128 256) frames=30 warmup=3
fi
want bench && for run in "cornell static cornell-box" "cornell dynamic dynamic-stress" \
  "sponza static sponza" "sponza dynamic sponza-dynamic"; do
  read -r name scenario scene <<<"$run"
  for v in "${res[@]}"; do
    tag="$name-$scenario-v$v"
    step "bench-$tag" 300 "$bin/bench" --scene "scenes/$scene.toml" --scenario "$scenario" \
      --modes sync,async,async-lagged,async-pipelined --width "$w" --height "$h" --set "gi.voxel_resolution=$v" \
      --frames "$frames" --warmup "$warmup" \
      --json "$out/bench-$tag.json" --timeline "$out/bench-$tag.svg" >"$out/bench-$tag.txt" 2>&1
  done
done
# ----- 3-. The schedule model (issue 40): each run above predicted from its own pass times and -----
# the submits recorded here (at a small image: they do not depend on it), beside its measurement.
want model && for j in "$out"/bench-{cornell,sponza}-{static,dynamic}-v*.json; do
  [ -f "$j" ] || continue
  tag="$(basename "$j" .json)"
  tag="${tag#bench-}"
  step "model-$tag" 300 "$bin/bench" --model "$j" --json "$out/model-$tag.json" >"$out/model-$tag.txt" 2>&1
done
# ----- 3a. The voxel layouts (issue 27): bricks against dense, same resolution, same run. -----
if [ "$quick" = 1 ]; then layout_res=(16 32); else layout_res=(128 256 512); fi
want layouts && for v in "${layout_res[@]}"; do
  for layout in bricks dense; do
    tag="layout-sponza-$layout-v$v"
    step "info-$tag" 120 "$bin/dvsgi" info scenes/sponza.toml --set "gi.voxel_resolution=$v" \
      --set "gi.voxel_layout=\"$layout\"" >>"$out/info-layouts.txt" 2>&1
    step "bench-$tag" 300 "$bin/bench" --scene scenes/sponza.toml --modes sync --width "$w" --height "$h" \
      --set "gi.voxel_resolution=$v" --set "gi.voxel_layout=\"$layout\"" --frames "$frames" --warmup "$warmup" \
      --json "$out/bench-$tag.json" >"$out/bench-$tag.txt" 2>&1
  done
done

# ----- 3b. The study's other techniques and its mix (issue 18), all modes: every frame redraws -----
# the maps and the volume (in a static scene a frame reuses them: issue 41).
want techniques && for run in "cornell cornell-box" "sponza sponza"; do
  read -r name scene <<<"$run"
  for mode in rsm lpv rsm+lpv; do
    tag="$name-${mode/+/-}"
    step "bench-$tag" 300 "$bin/bench" --scene "scenes/$scene.toml" --scenario redraw --modes sync,async,async-lagged,async-pipelined \
      --width "$w" --height "$h" --set "gi.mode=\"$mode\"" --frames "$frames" --warmup "$warmup" \
      --json "$out/bench-$tag.json" --timeline "$out/bench-$tag.svg" >"$out/bench-$tag.txt" 2>&1
  done
done
# ----- 3c. Reflections (issue 28): the specular cone against ray-traced reflections. -----
want reflections && for scene in cornell-mirror cornell-glossy; do
  for spec in cone rt; do
    tag="reflect-$scene-$spec"
    step "bench-$tag" 300 "$bin/bench" --scene "scenes/$scene.toml" --modes sync,async --width "$w" --height "$h" \
      --set "gi.specular=\"$spec\"" --frames "$frames" --warmup "$warmup" \
      --json "$out/bench-$tag.json" --timeline "$out/bench-$tag.svg" >"$out/bench-$tag.txt" 2>&1
  done
done
want reflections && for scene in cornell-box crytek-sponza; do
  for shadows in shadow-map rt; do
    tag="shadows-$scene-$shadows"
    have_scene "$scene" || { skip "bench-$tag" "no $scene in this checkout or bundle"; continue; }
    step "bench-$tag" 300 "$bin/bench" --scene "scenes/$scene.toml" --modes sync,async --width "$w" --height "$h" \
      --set "gi.shadows=\"$shadows\"" --frames "$frames" --warmup "$warmup" \
      --json "$out/bench-$tag.json" --timeline "$out/bench-$tag.svg" >"$out/bench-$tag.txt" 2>&1
  done
done

# ----- 4. Serial profile: every pass alone, host-timed, beside the timestamps. -----
want serial && for run in "cornell cornell-box ${res[0]}" "sponza sponza ${res[1]}"; do
  read -r name scene v <<<"$run"
  step "serial-$name-v$v" 300 "$bin/bench" --scene "scenes/$scene.toml" --modes sync,async \
    --width "$w" --height "$h" --set "gi.voxel_resolution=$v" --frames "$frames" --warmup "$warmup" \
    --serial-profile --json "$out/serial-$name-v$v.json" >"$out/serial-$name-v$v.txt" 2>&1
done
# ----- 4a. The G-buffer's time split (issue 41): vertex and raster, fragments, overdraw. -----
want raster && for scene in sponza crytek-sponza; do
  have_scene "$scene" || { skip "raster-$scene" "no $scene in this checkout or bundle"; continue; }
  step "raster-$scene" 300 "$bin/bench" --scene "scenes/$scene.toml" --modes sync --width "$w" --height "$h" \
    --set 'gi.mode="none"' --frames 3 --warmup 1 --error-frames 0 --raster-profile \
    --json "$out/raster-$scene.json" >"$out/raster-$scene.txt" 2>&1
done
want raster && for prepass in on off; do
  step "bench-prepass-sponza-$prepass" 300 "$bin/bench" --scene scenes/sponza.toml --width "$w" --height "$h" \
    --set "gi.voxel_resolution=${res[0]}" --set "render.depth_prepass=\"$prepass\"" --frames "$frames" \
    --warmup "$warmup" --json "$out/bench-prepass-sponza-$prepass.json" >"$out/bench-prepass-sponza-$prepass.txt" 2>&1
done

# ----- 5. A short sweep against the path-traced reference. -----
if [ "$quick" = 1 ]; then
  grid=(--grid voxel_resolution=16,32) sweep=(--spp 16 --width 32 --height 32 --frames 1)
else
  grid=(--grid voxel_resolution=64,128,256 --grid diffuse_cones=6,9)
  sweep=(--spp 1024 --width 480 --height 270 --frames 10)
fi
want sweep && step sweep-cornell 420 "$bin/dvsgi" sweep scenes/cornell-box.toml --out "$out/sweep-cornell" "${grid[@]}" "${sweep[@]}" \
  >"$out/sweep-cornell.txt" 2>&1
# The other techniques into the same directory: one frontier with every technique.
want sweep && step sweep-cornell-rsm-lpv 420 "$bin/dvsgi" sweep scenes/cornell-box.toml --out "$out/sweep-cornell" \
  "${sweep[@]}" --grid mode=rsm,lpv,rsm+lpv >>"$out/sweep-cornell.txt" 2>&1

# ----- 5b. What voxel resolution buys (issue 27): Sponza against the path tracer, by region. -----
if [ "$quick" = 1 ]; then
  acc_size=(--width 32 --height 18) acc_spp=16 acc_res=(16 32)
else
  acc_size=(--width 480 --height 270) acc_spp=4096 acc_res=(128 256 512)
fi
if want accuracy; then
  a="$out/accuracy-sponza"
  mkdir -p "$a"
  step accuracy-reference 300 "$bin/dvsgi" reference scenes/sponza.toml "${acc_size[@]}" --spp "$acc_spp" \
    --out "$a/reference.exr" >"$a/reference.txt" 2>&1
  step accuracy-reference-direct 120 "$bin/dvsgi" reference scenes/sponza.toml "${acc_size[@]}" --spp 1024 \
    --bounces 0 --out "$a/direct.exr" >>"$a/reference.txt" 2>&1
  for v in "${acc_res[@]}"; do
    for layout in dense bricks; do
      tag="v$v-$layout"
      step "accuracy-$tag" 300 "$bin/dvsgi" render scenes/sponza.toml "${acc_size[@]}" --schedule sync --frames 8 \
        --set "gi.voxel_resolution=$v" --set "gi.voxel_layout=\"$layout\"" --out "$a/$tag.exr" >"$a/$tag.txt" 2>&1
      step "accuracy-compare-$tag" 120 "$bin/dvsgi" compare "$a/$tag.exr" "$a/reference.exr" --scene scenes/sponza.toml \
        --ref-direct "$a/direct.exr" --json "$a/$tag.json" >>"$a/$tag.txt" 2>&1
      rm -f "$a/$tag.exr"
    done
  done
fi

# ----- 5c. The cone set and the cone filter (issue 43): what 16 cones and two taps buy, and cost. -----
if [ "$quick" = 1 ]; then
  cone_size=(--width 32 --height 18) cone_spp=16 cone_res=(16 32) cone_bench=(--width 64 --height 36 --frames 2 --warmup 1)
else
  cone_size=(--width 480 --height 270) cone_spp=4096 cone_res=(128 256) cone_bench=(--width 1920 --height 1080 --frames 30 --warmup 3)
fi
if want cones; then
  for scene in cornell-box sponza; do
    c="$out/cones-$scene"
    mkdir -p "$c"
    step "cones-$scene-reference" 300 "$bin/dvsgi" reference "scenes/$scene.toml" "${cone_size[@]}" --spp "$cone_spp" \
      --out "$c/reference.exr" >"$c/reference.txt" 2>&1
    step "cones-$scene-direct" 120 "$bin/dvsgi" reference "scenes/$scene.toml" "${cone_size[@]}" --spp 1024 \
      --bounces 0 --out "$c/direct.exr" >>"$c/reference.txt" 2>&1
    for filter in trilinear two-tap; do
      # Timed, one frontier per filter (the filter is a --set, not a sweep knob).
      step "cones-$scene-sweep-$filter" 300 "$bin/dvsgi" sweep "scenes/$scene.toml" --out "$c/sweep-$filter" \
        --set "gi.cone_filter=\"$filter\"" --grid "voxel_resolution=$(IFS=,; echo "${cone_res[*]}")" \
        --grid diffuse_cones=9,16 --spp "$cone_spp" "${cone_size[@]}" --frames 10 >"$c/sweep-$filter.txt" 2>&1
      for v in "${cone_res[@]}"; do
        for n in 9 16; do
          tag="v$v-c$n-$filter" set=(--set "gi.voxel_resolution=$v" --set "gi.diffuse_cones=$n" --set "gi.cone_filter=\"$filter\"")
          step "cones-$scene-$tag" 300 bash -c '"$@" --out "$0.exr" && "$@" --view indirect --out "$0-indirect.exr"' \
            "$c/$tag" "$bin/dvsgi" render "scenes/$scene.toml" "${cone_size[@]}" --schedule sync --frames 8 "${set[@]}" \
            >"$c/$tag.txt" 2>&1
          step "cones-$scene-compare-$tag" 120 "$bin/dvsgi" compare "$c/$tag.exr" "$c/reference.exr" --scene "scenes/$scene.toml" \
            "${set[@]}" --ref-direct "$c/direct.exr" --test-indirect "$c/$tag-indirect.exr" --json "$c/$tag.json" >>"$c/$tag.txt" 2>&1
          rm -f "$c/$tag.exr" "$c/$tag-indirect.exr"
        done
      done
    done
    rm -f "$c/reference.var.exr" "$c/direct.var.exr"
  done
  for filter in trilinear two-tap; do
    for n in 9 16; do
      tag="cones-sponza-c$n-$filter"
      step "bench-$tag" 300 "$bin/bench" --scene scenes/sponza.toml --modes sync "${cone_bench[@]}" \
        --set "gi.voxel_resolution=${cone_res[0]}" --set "gi.diffuse_cones=$n" --set "gi.cone_filter=\"$filter\"" \
        --json "$out/bench-$tag.json" >"$out/bench-$tag.txt" 2>&1
    done
  done
fi

# ----- 5d. The top presets and the footprints (issue 43): what quadrants cost in the pixels' cones
# and in the bounce's, on a GPU at a real image size (lavapipe's sweeps are at 128^2 and 160x90).
if want footprints; then
  for scenario in static redraw; do
    for preset in ultra max max-bounce; do
      set=(--preset "${preset%%-*}")
      [ "$preset" = max-bounce ] && set+=(--set 'gi.bounce_footprint="quadrants"')
      tag="footprint-sponza-$scenario-$preset"
      step "bench-$tag" 300 "$bin/bench" --scene scenes/sponza.toml --scenario "$scenario" --modes sync \
        "${cone_bench[@]}" "${set[@]}" --json "$out/bench-$tag.json" >"$out/bench-$tag.txt" 2>&1
    done
  done
fi

# ----- 5e. The backs that close a solid (issue 43, fifteenth part): gi.plane_backs = "closed", the
# default, by region on Dabrovic's Sponza at every grid (lit and dark ran on the H200 at 6be6713;
# their images have not changed since), and what it costs: the mips against lit backs, and the
# pass that marks the static voxels' backs in the first frame (--warmup 0).
if [ "$quick" = 1 ]; then
  backs_size=(--width 32 --height 18) backs_spp=16 backs_res=(16 32) backs_bench=(--width 64 --height 36 --frames 2)
else
  backs_size=(--width 480 --height 270) backs_spp=4096 backs_res=(128 256 512) backs_bench=(--width 1920 --height 1080 --frames 30)
fi
if want backs; then
  b="$out/backs-sponza"
  mkdir -p "$b"
  step backs-reference 300 "$bin/dvsgi" reference scenes/sponza.toml "${backs_size[@]}" --spp "$backs_spp" \
    --out "$b/reference.exr" >"$b/reference.txt" 2>&1
  step backs-reference-direct 120 "$bin/dvsgi" reference scenes/sponza.toml "${backs_size[@]}" --spp 1024 \
    --bounces 0 --out "$b/direct.exr" >>"$b/reference.txt" 2>&1
  for v in "${backs_res[@]}"; do
    tag="v$v-closed" set=(--set "gi.voxel_resolution=$v" --set 'gi.plane_backs="closed"')
    step "backs-$tag" 300 bash -c '"$@" --out "$0.exr" && "$@" --view indirect --out "$0-indirect.exr"' \
      "$b/$tag" "$bin/dvsgi" render scenes/sponza.toml "${backs_size[@]}" --schedule sync --frames 8 "${set[@]}" \
      >"$b/$tag.txt" 2>&1
    step "backs-compare-$tag" 120 "$bin/dvsgi" compare "$b/$tag.exr" "$b/reference.exr" --scene scenes/sponza.toml \
      "${set[@]}" --ref-direct "$b/direct.exr" --test-indirect "$b/$tag-indirect.exr" --json "$b/$tag.json" >>"$b/$tag.txt" 2>&1
    rm -f "$b/$tag.exr" "$b/$tag-indirect.exr"
    for backs in lit closed; do
      tag="backs-sponza-v$v-$backs"
      step "bench-$tag" 300 "$bin/bench" --scene scenes/sponza.toml --modes sync "${backs_bench[@]}" --warmup 0 \
        --set "gi.voxel_resolution=$v" --set "gi.plane_backs=\"$backs\"" --json "$out/bench-$tag.json" \
        >"$out/bench-$tag.txt" 2>&1
    done
  done
  rm -f "$b/reference.var.exr" "$b/direct.var.exr"
fi

# ----- 6. Cost curves: per-pass cost against voxel resolution, pixels and triangles. -----
if [ "$quick" = 1 ]; then
  curves=(--resolutions 16,32 --sizes 32,64 --size 32 --resolution 16 --frames 1)
else
  curves=(--resolutions 32,64,128,256 --sizes 256,512,1024,2048 --size 512 --resolution 128 --frames 5)
fi
if want curves && command -v python3 >/dev/null; then
  step cost-curves 300 python3 tools/cost-curves.py --bench "$bin/bench" --out "$out/curves" "${curves[@]}" \
    --triangle-scenes scenes/cornell-box.toml,scenes/cornell-sphere.toml,scenes/sponza.toml >"$out/curves.txt" 2>&1
fi

# ----- Summary. -----
{
  echo "# dvsgi GPU report: $device"
  echo
  echo "Written by \`tools/gpu-report.sh\` on $(date -u '+%Y-%m-%d %H:%M UTC'), commit $(head -1 "$out/commit.txt" 2>/dev/null)."
  echo "Driver: $(sed -n 's/^  driver: //p' "$out/info.txt" | head -1). Queue topology: $(sed -n 's/^  queue topology: //p' "$out/info.txt" | head -1)."
  echo
  echo "| step | exit | seconds |"
  echo "|---|---|---|"
  tail -n +2 "$out/steps.tsv" | awk -F'\t' '{ printf "| %s | %s | %s |\n", $1, $2, $3 }'
  echo
  echo "Per-mode frame times (host median, ms) and ratio to sync, from the bench JSON files:"
  echo
  if command -v python3 >/dev/null; then
    python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
print("| run | sync | async | async-lagged | async-pipelined | async/sync | lagged/sync | pipelined/sync | GPU span sync / async (ms) |")
print("|---|---|---|---|---|---|---|---|---|")
for f in sorted(out.glob("bench-*.json")):
    r = json.loads(f.read_text())
    m = {x["mode"]: x for x in r["modes"]}
    med = lambda k: "%.2f" % m[k]["frame_host_ms"]["median"] if k in m else "-"
    rat = lambda k: "%.3f" % m[k]["frame_ratio_to_sync"] if k in m and m[k].get("frame_ratio_to_sync") else "-"
    span = lambda k: "%.2f" % m[k]["gpu_span_ms"]["median"] if k in m and m[k].get("gpu_span_ms") else "-"
    print(f"| {f.stem[6:]} | {med('sync')} | {med('async')} | {med('async-lagged')} | {med('async-pipelined')} | {rat('async')} | {rat('async-lagged')} | {rat('async-pipelined')} | {span('sync')} / {span('async')} |")
PY
  fi
} >"$out/README.md" 2>>"$out/report.log"
log "done: $failed step(s) failed; see $out/README.md"
[ "$failed" -eq 0 ]
