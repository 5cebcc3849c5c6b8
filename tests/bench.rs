//! The `bench` binary end to end with small settings: every mode runs, the JSON report is
//! valid against docs/bench-schema.json, the timeline picture has a lane per queue and mode.

mod common;

use common::{bench, repo};

fn schema() -> jsonschema::Validator {
    let text = std::fs::read_to_string(repo().join("docs/bench-schema.json")).unwrap();
    jsonschema::validator_for(&serde_json::from_str(&text).unwrap()).expect("a valid JSON Schema")
}

// Long: one bench run, then every field of its report and timeline checked against the schema.
#[test]
fn bench_smoke_writes_schema_valid_json_and_a_timeline() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let svg = dir.path().join("timeline.svg");
    for scenario in ["static", "dynamic"] {
        let scene = if scenario == "static" { "scenes/cornell-box.toml" } else { "scenes/dynamic-stress.toml" };
        let o = bench(&[
            "--scene",
            scene,
            "--scenario",
            scenario,
            "--modes",
            "sync,async,async-lagged,async-pipelined",
            "--frames",
            "3",
            "--warmup",
            "2",
            "--width",
            "32",
            "--height",
            "32",
            "--set",
            "gi.voxel_resolution=16",
            "--set",
            "gi.voxel_layout=\"bricks\"",
            "--serial-profile",
            "--error-frames",
            "2",
            "--json",
            json.to_str().unwrap(),
            "--timeline",
            svg.to_str().unwrap(),
        ]);
        let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
        assert!(o.status.success(), "{scenario}: {err}");
        assert!(!err.contains("validation"), "{err}");
        assert!(out.contains("queue topology:") && out.contains("ratio to sync"), "{out}");
        let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let validator = schema();
        let errors: Vec<String> =
            validator.iter_errors(&report).map(|e| format!("{e} at {}", e.instance_path)).collect();
        assert!(errors.is_empty(), "schema errors: {errors:#?}");
        // The typed report reads it back too (serde, deny_unknown_fields).
        let typed: dvsgi::bench::Report = serde_json::from_value(report).unwrap();
        assert_eq!(typed.scenario, scenario);
        let names: Vec<_> = typed.modes.iter().map(|m| m.mode.as_str()).collect();
        assert_eq!(names, ["sync", "async", "async-lagged", "async-pipelined"]);
        for m in &typed.modes {
            assert_eq!(m.frame_host_samples.len(), 3);
            let pipelined = m.mode == "async-pipelined";
            assert_eq!((m.latency_frames, m.frame_copies > 1), (u32::from(pipelined), pipelined), "{}", m.mode);
            assert_eq!(m.frame_copies_bytes > 0, pipelined, "{}: memory of the copies", m.mode);
            assert_eq!(m.host_waits.in_frame, 0, "{}: no host wait inside a frame", m.mode);
            assert!(m.frame_host_mean_ms > 0.0);
            assert!(m.passes.iter().any(|p| p.name == "cone trace" && p.serial_host_ms.is_some()), "{m:?}");
            let trace_queue = &m.passes.iter().find(|p| p.name == "cone trace").unwrap().queue;
            if typed.device.timestamps_calibrated || !m.timeline.is_empty() {
                assert_eq!(trace_queue, if m.mode == "sync" { "graphics" } else { "compute" });
            }
            assert_eq!(m.image_error_vs_sync.is_some(), m.mode != "sync");
            assert_eq!(m.frame_ratio_to_sync.is_some(), m.mode != "sync");
            // The work list after the last frame: the same occupancy in every mode of a
            // static scene (the grid is the scene's, whatever the schedule).
            let o = m.occupancy.expect("occupancy of the voxel work list");
            assert_eq!((o.resolution, o.voxels), (16, 4096), "{o:?}");
            assert!(o.occupied > 0 && o.occupied < o.voxels && o.static_occupied <= o.occupied, "{o:?}");
            assert!(o.bricks8 <= o.bricks4 && o.bricks4 <= o.occupied, "{o:?}");
            if scenario == "static" {
                assert_eq!(Some(o), typed.modes[0].occupancy, "{}", m.mode);
            }
            // Nothing the shadow maps are drawn from changes in the static scene: the first
            // (warm-up) frame of each copy of the frame draws them (async-pipelined has two,
            // hence two warm-up frames), no timed frame does. The dynamic scene's light
            // circles: every frame draws its views.
            let shadows = m.passes.iter().any(|p| p.name.starts_with("shadow map"));
            assert_eq!(shadows, scenario == "dynamic", "{}: {:?}", m.mode, m.passes);
            // The bricked layout: the resident full-resolution bricks are the occupied 8^3 bricks
            // and those whose aprons hold an occupied voxel, in a map of (16 / 8 + 1)^3 bricks.
            let v = m.voxel_memory.as_ref().expect("the voxel layout");
            assert_eq!(v.layout, "bricks", "{v:?}");
            assert!(u64::from(v.pools[0].resident) >= o.bricks8, "{v:?}");
            assert_eq!((v.pools[0].level_side, v.pools[0].grid_bricks, v.pools[0].brick_stride), (16, 27, 9), "{v:?}");
            assert!(v.pools.iter().all(|p| p.resident <= p.capacity && p.bytes > 0), "{v:?}");
            assert!(v.bytes > 0 && v.dense_bytes > 0, "{v:?}");
        }
        assert!(out.contains("voxel layout: bricks of 8³"), "{out}");
        assert!(out.contains("occupied voxels (work list):"), "{out}");
        if common::under_split_queues() {
            assert!(typed.device.queue_topology.contains("dedicated compute-only family"), "{:?}", typed.device);
        }
        // Async work on its own queue computes the same image, bit for bit, in every frame, the
        // moving scene's too: two renderers voxelize alike (order-independent sums).
        for i in [1, 3] {
            let e = typed.modes[i].image_error_vs_sync.as_ref().unwrap();
            assert_eq!((e.mean_relative, e.max_relative), (0.0, 0.0), "{scenario}: {} vs sync: {e:?}", names[i]);
        }
        if scenario == "dynamic" {
            // The lagged image trails the moving light.
            let lag = typed.modes[2].image_error_vs_sync.as_ref().unwrap().mean_relative;
            assert!(lag > 0.0, "{lag}");
        }
        let picture = std::fs::read_to_string(&svg).unwrap();
        assert!(picture.starts_with("<svg"), "{picture}");
        let lanes = [
            "sync · graphics",
            "sync · compute",
            "async · compute",
            "async-lagged · graphics",
            "async-pipelined · compute",
        ];
        for lane in lanes {
            assert!(picture.contains(lane), "{lane} lane missing");
        }
        assert!(picture.contains("<title>cone trace (compute)"), "a cone-trace bar on the compute lane");
    }
}

/// `--scenario redraw`: nothing moves, yet every frame draws what a static frame reuses (the
/// shadow maps, the reflective shadow maps, the propagation volume's injection and
/// propagation): the cost of a frame in which everything changed, in a scene without motion.
/// The static scenario's timed frames (after one warm-up frame) draw none of them.
#[test]
fn the_redraw_scenario_draws_every_map_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let mut args = vec!["--scene", "scenes/cornell-box.toml", "--modes", "sync", "--frames", "2", "--warmup", "1"];
    args.extend(["--width", "16", "--height", "16", "--set", "gi.mode=\"lpv\"", "--set", "gi.rsm_size=32"]);
    args.extend(["--set", "gi.lpv_resolution=8", "--error-frames", "0", "--json", json.to_str().unwrap()]);
    for scenario in ["redraw", "static"] {
        let o = bench(&[&args[..], &["--scenario", scenario]].concat());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let errors: Vec<String> = schema().iter_errors(&report).map(|e| format!("{e}")).collect();
        assert!(errors.is_empty(), "schema errors: {errors:#?}");
        let typed: dvsgi::bench::Report = serde_json::from_value(report).unwrap();
        assert_eq!(typed.scenario, scenario);
        let passes = &typed.modes[0].passes;
        for pass in ["shadow maps", "reflective shadow maps", "lpv inject", "lpv propagate"] {
            let ran = passes.iter().any(|p| p.name == pass);
            assert_eq!(ran, scenario == "redraw", "{scenario}: {pass} in {passes:?}");
        }
        assert!(passes.iter().any(|p| p.name == "lpv lookup"), "{scenario}: {passes:?}");
    }
}

/// `--raster-profile` splits the G-buffer: the pass, a depth prepass of its opaque draws and
/// the G-buffer over that depth, each timed; with pipeline statistics (lavapipe has them), the
/// pass over the prepass shades each covered pixel exactly once (no alpha masks here), the
/// frame's pass at least once, and both draw the scene's triangles.
#[test]
fn the_raster_profile_splits_the_gbuffer() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let mut args = vec!["--scene", "scenes/cornell-box.toml", "--modes", "sync", "--frames", "1", "--warmup", "0"];
    args.extend(["--width", "32", "--height", "32", "--set", "gi.mode=\"none\"", "--error-frames", "0"]);
    args.extend(["--raster-profile", "--json", json.to_str().unwrap()]);
    let o = bench(&args);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.contains("raster profile (sync): 1024 pixels"), "{out}");
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let errors: Vec<String> = schema().iter_errors(&report).map(|e| format!("{e}")).collect();
    assert!(errors.is_empty(), "schema errors: {errors:#?}");
    let typed: dvsgi::bench::Report = serde_json::from_value(report).unwrap();
    let r = typed.modes[0].raster.as_ref().expect("the raster profile");
    let names: Vec<&str> = r.passes.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["gbuffer", "gbuffer depth prepass (opaque draws)", "gbuffer over the prepass"]);
    assert!(r.covered_pixels > 0 && r.covered_pixels <= r.pixels, "{r:?}");
    assert!(r.passes.iter().all(|p| p.serial_host_ms.is_some_and(|s| s.median > 0.0)), "{r:?}");
    if let (Some(full), Some(over)) = (r.passes[0].counts, r.passes[2].counts) {
        assert_eq!(over.fragment_invocations, r.covered_pixels, "{r:?}");
        assert!(full.fragment_invocations >= r.covered_pixels, "{r:?}");
        let triangles = dvsgi::scene::load(&common::repo().join("scenes/cornell-box.toml"), &Default::default())
            .unwrap()
            .triangle_count() as u64;
        assert_eq!((full.primitives, over.primitives), (triangles, triangles), "{r:?}");
    }
}

#[test]
fn bench_rejects_impossible_requests_without_writing() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("b.json");
    // Nothing moves in the Cornell box: the dynamic scenario would measure nothing.
    let o = bench(&["--scene", "scenes/cornell-box.toml", "--scenario", "dynamic", "--json", json.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("nothing in this scene moves"), "{err}");
    let o = bench(&["--scene", "scenes/cornell-box.toml", "--modes", "sync,turbo"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown schedule mode 'turbo'"));
    let o = bench(&["--scene", "scenes/cornell-box.toml", "--json", "/nonexistent-dir/b.json"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent-dir"));
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none(), "nothing written");
}

/// `bench --model` on `report` at `size`, recording `frames` timed frames after one warm-up in
/// `scenario`; its JSON.
fn model(report: &str, scenario: &str, size: (u32, u32), frames: u32) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("model.json");
    let (w, h, f) = (size.0.to_string(), size.1.to_string(), frames.to_string());
    let args =
        ["--model", report, "--scenario", scenario, "--frames", &f, "--warmup", "1", "--width", &w, "--height", &h];
    let o = bench(&[&args[..], &["--json", json.to_str().unwrap()]].concat());
    let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{err}");
    assert!(out.contains("model error") && !out.contains("warning:"), "{out}");
    let value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let text = std::fs::read_to_string(repo().join("docs/bench-model-schema.json")).unwrap();
    let validator = jsonschema::validator_for(&serde_json::from_str(&text).unwrap()).expect("a valid JSON Schema");
    let errors: Vec<String> = validator.iter_errors(&value).map(|e| format!("{e} at {}", e.instance_path)).collect();
    assert!(errors.is_empty(), "schema errors: {errors:#?}");
    value
}

// Long (two bench runs of four modes): the schedule model against a committed NVIDIA H200
// report. The report's version redrew the shadow maps every frame, which the redraw scenario
// does now; the frames recorded here are then exactly the measured ones, and each measured
// mode's modelled host median is within 3% of the measured one. The report predates
// async-pipelined: from async's pass times, it is modelled at most 0.65 of sync (issue 40's
// target for Cornell 128^3). The submits do not depend on the image size: another size gives
// the same prediction.
#[test]
fn the_schedule_model_predicts_an_h200_report_within_3_percent() {
    let report = "docs/bench/nvidia-h200/bench-cornell-static-v128.json";
    // Six frames: with two in flight, the first two start at once and the median of three
    // would be the first frame's whole span, not the steady state.
    let a = model(report, "redraw", (48, 27), 6);
    let modes = a["modes"].as_array().unwrap();
    let names: Vec<&str> = modes.iter().map(|m| m["mode"].as_str().unwrap()).collect();
    assert_eq!(names, ["sync", "async", "async-lagged", "async-pipelined"]);
    let pipelined = &modes[3];
    let ratio = pipelined["predicted_ratio_to_sync"].as_f64().unwrap();
    assert!(ratio <= 0.65, "async-pipelined modelled at {ratio} of sync: {pipelined}");
    assert_eq!(pipelined["error"], serde_json::Value::Null, "not measured: {pipelined}");
    for m in &modes[..3] {
        assert_eq!(m["structure_differences"].as_array().unwrap().len(), 0, "{m}");
        let error = m["error"].as_f64().unwrap();
        assert!(
            error.abs() <= 0.03,
            "{}: modelled {} against measured {}",
            m["mode"],
            m["predicted"]["frame_host_ms"]["median"],
            m["measured_frame_host_ms"]
        );
        // Each queue's busy time is the report's sum of that queue's passes.
        for q in ["graphics", "compute"] {
            let (modelled, measured) = (
                m["predicted"][format!("{q}_busy_ms")]["median"].as_f64().unwrap(),
                m[format!("measured_{q}_busy_ms")].as_f64().unwrap(),
            );
            assert!((modelled - measured).abs() <= 0.03 * measured.max(0.1), "{q}: {modelled} against {measured}");
        }
    }
    let b = model(report, "redraw", (96, 54), 6);
    for (x, y) in modes.iter().zip(b["modes"].as_array().unwrap()) {
        assert_eq!(x["predicted"], y["predicted"], "the same submits at another image size");
    }
}
