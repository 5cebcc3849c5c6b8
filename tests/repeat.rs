//! Results repeat: the same scene and settings give the same bytes on the same device,
//! whatever the number of llvmpipe threads (4 here, on purpose: its workgroups and fragments
//! then run in a different order on every run) or the queue a pass runs on. The voxel grids
//! are 128^3: llvmpipe rasterizes in tiles of 64x64 pixels, one thread each, so a smaller
//! grid's voxelization runs on one thread and would repeat even with order-dependent averages. Each render is a
//! `dvsgi render` of its own (a new device, new threads), written as EXR (linear radiance,
//! 32-bit float), and the files must be equal byte for byte: two `sync` renders, and `async`
//! (the GI work on the compute queue) against `sync`.

mod common;

use common::*;

/// `dvsgi render SCENE` at 48x48, two frames, with `sets` (KEY=VALUE) and `schedule`, into
/// `out`, under 4 llvmpipe threads; the EXR's bytes.
fn render(scene: &str, sets: &[&str], schedule: &str, out: &std::path::Path) -> Vec<u8> {
    render_with(scene, sets, schedule, out, &[])
}

/// `render`, with `env` set too.
fn render_with(scene: &str, sets: &[&str], schedule: &str, out: &std::path::Path, env: &[(&str, &str)]) -> Vec<u8> {
    let mut args: Vec<String> = Vec::new();
    for s in sets {
        args.extend(["--set".to_string(), s.to_string()]);
    }
    let out_arg = out.to_str().unwrap().to_string();
    args.extend(
        [
            "render",
            scene,
            "--width",
            "48",
            "--height",
            "48",
            "--frames",
            "2",
            "--schedule",
            schedule,
            "--out",
            &out_arg,
        ]
        .map(String::from),
    );
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let mut env = env.to_vec();
    env.push(("LP_NUM_THREADS", "4"));
    let o = dvsgi_with(&args, &env);
    assert!(o.status.success(), "dvsgi {args:?}: {}", stderr(&o));
    assert!(!stderr(&o).contains("validation"), "{}", stderr(&o));
    std::fs::read(out).unwrap()
}

/// Two `sync` renders and an `async` one of `scene` with `sets`: the same bytes.
fn assert_repeats(scene: &str, sets: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let first = render(scene, sets, "sync", &dir.path().join("sync1.exr"));
    for (schedule, name) in [("sync", "sync2.exr"), ("async", "async.exr")] {
        let again = render(scene, sets, schedule, &dir.path().join(name));
        assert_eq!(first.len(), again.len(), "{scene} {sets:?}: {schedule} file size");
        let differing = first.iter().zip(&again).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "{scene} {sets:?}: {differing} bytes of the {schedule} image differ from sync's");
    }
}

#[test]
fn the_cornell_box_repeats_byte_for_byte_with_every_technique() {
    for mode in ["none", "vct", "rsm", "lpv", "rsm+lpv"] {
        let gi = format!("gi.mode=\"{mode}\"");
        assert_repeats("scenes/cornell-box.toml", &[&gi, "gi.voxel_resolution=128"]);
    }
}

/// Bricked volumes (slots handed out in grid order), and the dynamic scene (revoxelized every
/// update: the dynamic voxels are appended as their fragments arrive, bricks released and
/// allocated anew), bricked with closed backs (marked after every revoxelization).
#[test]
fn bricks_and_moving_objects_repeat_byte_for_byte() {
    assert_repeats("scenes/cornell-box.toml", &["gi.voxel_layout=\"bricks\"", "gi.voxel_resolution=128"]);
    for (layout, backs) in [("dense", "lit"), ("bricks", "closed")] {
        let layout = format!("gi.voxel_layout=\"{layout}\"");
        let backs = format!("gi.plane_backs=\"{backs}\"");
        assert_repeats("scenes/dynamic-test.toml", &[&layout, &backs, "gi.voxel_resolution=128"]);
    }
}

/// The glossy box (specular cones, two bounces interleaved over updates) and Sponza (66k
/// triangles meeting in few voxels: many samples per voxel; and the mix of RSM and LPV).
#[test]
fn the_glossy_box_and_sponza_repeat_byte_for_byte() {
    assert_repeats("scenes/cornell-glossy.toml", &["gi.voxel_resolution=128", "gi.bounces=2"]);
    assert_repeats("scenes/sponza.toml", &["gi.voxel_resolution=128"]);
    assert_repeats("scenes/sponza.toml", &["gi.mode=\"rsm+lpv\""]);
}

/// The cone tracers are built twice (glsl/include/cone.glsl, SAMPLER_LOOP): with the voxel
/// samplers' loops kept, which CPU drivers run, and unrolled, which GPUs run. On one device the
/// two give the same bytes: the whole footprint and the quadrants' four parts, the directional
/// levels of bricked pools (two blended in the loop) and of two-tap samples.
#[test]
fn the_gpus_unrolled_cone_tracer_gives_the_kept_one_s_bytes() {
    let configurations: [&[&str]; 2] = [
        &["gi.voxel_layout=\"bricks\"", "gi.footprint=\"quadrants\"", "gi.voxel_resolution=64"],
        &["gi.cone_filter=\"two-tap\"", "gi.voxel_resolution=64"],
    ];
    for v in ["kept", "unrolled"] {
        let o = dvsgi_with(&["info"], &[("DVSGI_CONE_SAMPLERS", v)]);
        assert!(stdout(&o).contains(&format!("GI sampler loops: {v}")), "{}", stdout(&o));
    }
    let dir = tempfile::tempdir().unwrap();
    for sets in configurations {
        let [kept, unrolled] = ["kept", "unrolled"].map(|v| {
            let out = dir.path().join(format!("{v}.exr"));
            render_with("scenes/cornell-box.toml", sets, "sync", &out, &[("DVSGI_CONE_SAMPLERS", v)])
        });
        assert_eq!(kept.len(), unrolled.len(), "{sets:?}: file size");
        let differing = kept.iter().zip(&unrolled).filter(|(a, b)| a != b).count();
        assert_eq!(
            differing, 0,
            "{sets:?}: {differing} bytes of the unrolled build's image differ from the kept one's"
        );
    }
}
