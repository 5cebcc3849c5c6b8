//! What an unkind afternoon with the CLI found (issue 15), each as a regression test: outputs
//! on a full disk, several outputs at once, outputs that are the same file, unwritable
//! targets, unbounded counts, a closed stdout.

mod common;
use common::{bench, dvsgi, repo, stderr, stdout};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// A tiny tmpfs, filled up, mounted for the test's life (root only: elsewhere `None`, and the
/// test says it skipped).
struct FullDisk {
    dir: tempfile::TempDir,
}

impl FullDisk {
    fn new() -> Option<FullDisk> {
        let dir = tempfile::tempdir().ok()?;
        let mounted = Command::new("mount")
            .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
            .arg(dir.path())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if !mounted {
            eprintln!("skipped: mounting a tmpfs needs root (the full-disk case runs in CI as root)");
            return None;
        }
        // Fill it: the write that fails with ENOSPC leaves the disk full.
        let _ = std::fs::write(dir.path().join("filler"), vec![0u8; 1 << 20]);
        Some(FullDisk { dir })
    }
    fn path(&self) -> &Path {
        self.dir.path()
    }
    /// Everything on the disk but the filler.
    fn left(&self) -> Vec<String> {
        std::fs::read_dir(self.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n != "filler")
            .collect()
    }
}

impl Drop for FullDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(self.dir.path()).status();
    }
}

fn render(out: &[&Path], extra: &[&str]) -> std::process::Output {
    let mut args = vec!["render", "scenes/cornell-box.toml", "--gi", "none", "--width", "64", "--height", "64"];
    for o in out {
        args.extend(["--out", o.to_str().unwrap()]);
    }
    args.extend(extra);
    dvsgi(&args)
}

#[test]
fn a_full_disk_fails_every_output_and_leaves_nothing() {
    let Some(disk) = FullDisk::new() else { return };
    for name in ["x.png", "x.exr"] {
        let out = disk.path().join(name);
        let o = render(&[&out], &[]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}: a write to a full disk must fail:\n{}", stdout(&o));
        assert!(err.contains(name) && err.contains("No space left"), "{name}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(disk.left().is_empty(), "{name}: left behind: {:?}", disk.left());
    }
    // Reports too: the bench JSON and timeline.
    let json = disk.path().join("b.json");
    let o = dvsgi_bench(&["--json", json.to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).contains("b.json"), "{}", stderr(&o));
    assert!(disk.left().is_empty(), "{:?}", disk.left());
}

#[test]
fn several_outputs_are_written_all_or_none() {
    let Some(disk) = FullDisk::new() else { return };
    let dir = tempfile::tempdir().unwrap();
    let ok = dir.path().join("x.png");
    let o = render(&[&ok, &disk.path().join("y.exr")], &[]);
    assert!(!o.status.success(), "{}", stderr(&o));
    assert!(!ok.exists(), "x.png was written although y.exr failed");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "no temporary file is left");
}

#[test]
fn outputs_that_are_the_same_file_are_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = d.join("a.png");
    let o = render(&[&a, &d.join("./a.png")], &[]);
    assert!(!o.status.success() && stderr(&o).contains("same file"), "{}", stderr(&o));
    // A reference's variance file is one of its outputs.
    let (r, v) = (d.join("r.exr"), d.join("r.var.exr"));
    let o = dvsgi(&[
        "reference",
        "scenes/cornell-box.toml",
        "--spp",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "--out",
        r.to_str().unwrap(),
        "--out",
        v.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success() && err.contains("r.var.exr") && err.contains("same file"), "{err}");
    assert_eq!(std::fs::read_dir(d).unwrap().count(), 0, "nothing written");
}

#[test]
fn an_unwritable_target_is_refused_before_the_work() {
    // /sys refuses new files even to root.
    let start = std::time::Instant::now();
    let o = dvsgi(&[
        "reference",
        "scenes/cornell-box.toml",
        "--spp",
        "100000",
        "--width",
        "256",
        "--height",
        "256",
        "--out",
        "/sys/r.exr",
    ]);
    let err = stderr(&o);
    assert!(!o.status.success() && err.contains("/sys/r.exr") && err.contains("cannot create files"), "{err}");
    assert!(!stdout(&o).contains("traced"), "nothing was traced");
    assert!(start.elapsed().as_secs() < 60, "refused up front, not after 100000 spp");
    // A directory named as the output file.
    let dir = tempfile::tempdir().unwrap();
    let o = dvsgi(&["compare", "tests/data/cornell-64.exr", "tests/data/cornell-64.exr", "--json", "."]);
    let err = stderr(&o);
    assert!(!o.status.success() && err.contains("is a directory"), "{err}");
    let o = render(&[dir.path()], &[]);
    assert!(!o.status.success(), "{}", stderr(&o));
}

/// `bench` on a tiny direct-light Cornell box, one sync frame, with `extra` arguments.
fn dvsgi_bench(extra: &[&str]) -> std::process::Output {
    let base = [
        "--scene",
        "scenes/cornell-box.toml",
        "--modes",
        "sync",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--error-frames",
        "0",
        "--width",
        "16",
        "--height",
        "16",
        "--set",
        "gi.mode=\"none\"",
    ];
    bench(&[&base[..], extra].concat())
}

#[test]
fn counts_and_thresholds_are_bounded() {
    for args in [
        &["--warmup", "4000000000"][..],
        &["--warmup", "1000000000"],
        &["--error-frames", "1000000000"],
        &["--width", "0"],
        &["--dt", "nan"],
    ] {
        let start = std::time::Instant::now();
        let o = dvsgi_bench(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: a usage error\n{}", stderr(&o));
        assert!(start.elapsed().as_secs() < 30, "{args:?}: refused at once");
    }
    let o = dvsgi_bench(&["--timeline", "t.png"]);
    assert!(!o.status.success() && stderr(&o).contains(".svg"), "{}", stderr(&o));
    let soak =
        |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_soak")).args(args).current_dir(repo()).output().unwrap();
    for (bad, name) in [
        ("--max-drift=nan", "--max-drift"),
        ("--max-drift=-1", "--max-drift"),
        ("--max-rss-growth-mib=inf", "--max-rss-growth-mib"),
        ("--dt=0", "--dt"),
    ] {
        let o = soak(&[bad]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains(name), "{bad}: {}", stderr(&o));
    }
    // A soak that runs with thresholds of zero is not a usage error: it fails (exit 3) exactly
    // when what it reports grew or drifted (lavapipe's resident memory grows a little; a GPU
    // driver's may not, and a deterministic image does not drift).
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("soak.json");
    let o = soak(&[
        "--modes",
        "sync",
        "--frames",
        "3",
        "--sample-every",
        "1",
        "--set",
        "gi.voxel_resolution=8",
        "--max-drift",
        "0",
        "--max-rss-growth-mib",
        "0",
        "--json",
        json.to_str().unwrap(),
    ]);
    // The verdict from the samples it recorded (growth: the last sample against the second).
    let out = stdout(&o);
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let samples = report["modes"][0]["samples"].as_array().expect("samples").clone();
    let at = |i: usize, key: &str| samples[i][key].as_f64().unwrap_or_else(|| panic!("{key}: {report}"));
    let last = samples.len() - 1;
    let grew = |key: &str| at(last, key) != at(1, key);
    let broken = at(last, "rss_bytes") > at(1, "rss_bytes")
        || ["gpu_allocated_bytes", "gpu_block_bytes", "gpu_allocations"].iter().any(|k| grew(k))
        || (0..=last).any(|i| at(i, "drift") > 0.0);
    assert_eq!(o.status.code(), Some(if broken { 3 } else { 0 }), "{out}{}", stderr(&o));
    assert_eq!(out.contains("FAILED: memory grew or the image drifted"), broken, "{out}");
}

/// `dvsgi info | head -1`: a closed stdout ends the output, it is no crash, and the files a
/// command writes are still written.
#[test]
fn a_closed_stdout_is_the_end_of_output_not_a_crash() {
    let run = |args: &[&str]| {
        let mut child = Command::new(env!("CARGO_BIN_EXE_dvsgi"))
            .args(args)
            .current_dir(repo())
            .env("DVSGI_VALIDATION", "1")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take()); // the reader goes away before anything is printed
        child.wait_with_output().unwrap()
    };
    let o = run(&["info"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dir = tempfile::tempdir().unwrap();
    let png: PathBuf = dir.path().join("x.png");
    let args = ["render", "scenes/cornell-box.toml", "--gi", "none", "--width", "16", "--height", "16", "-v"];
    let o = run(&[&args[..], &["--out", png.to_str().unwrap()]].concat());
    let err = stderr(&o);
    assert!(o.status.success() && !err.contains("panicked"), "{err}");
    assert!(png.exists(), "the image is written even though nobody reads stdout");
}

#[test]
fn a_model_of_a_missing_or_foreign_report_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.json");
    let o = bench(&["--model", missing.to_str().unwrap()]);
    assert!(
        !o.status.success() && stderr(&o).contains("none.json") && stderr(&o).contains("cannot read"),
        "{}",
        stderr(&o)
    );
    let foreign = dir.path().join("sweep.json");
    std::fs::write(&foreign, r#"{"schema": "dvsgi-sweep/1", "rows": []}"#).unwrap();
    let o = bench(&["--model", foreign.to_str().unwrap()]);
    let err = stderr(&o);
    assert!(!o.status.success() && err.contains("sweep.json") && err.contains("not a bench report"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // A model writes no timeline.
    let o = bench(&["--model", "docs/bench/nvidia-h200/bench-cornell-lpv.json", "--timeline", "t.svg"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
