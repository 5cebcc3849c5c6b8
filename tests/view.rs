//! `dvsgi view` end to end under a virtual X display (Xvfb): lavapipe presents through the X11
//! surface, a script drives the viewer, and what it captures must be what `dvsgi render`
//! makes of the scene file it writes. Validation is on in every run.

mod common;

use common::{repo, stderr, stdout};
use std::path::Path;
use std::process::{Command, Output};

/// `dvsgi view` with `args` under `xvfb-run` (a free display, 24-bit screen), validation on
/// and 4 llvmpipe threads (renders repeat byte for byte whatever the threads: tests/repeat.rs).
/// `None` without xvfb-run outside CI (CI installs it: tools/setup.sh).
fn view(args: &[&str]) -> Option<Output> {
    if Command::new("xvfb-run").arg("--help").output().is_err() {
        assert!(std::env::var_os("CI").is_none(), "xvfb-run is missing: tools/setup.sh installs xvfb");
        eprintln!("skipped: no xvfb-run (apt-get install xvfb)");
        return None;
    }
    let mut c = Command::new("xvfb-run");
    c.args(["-a", "-s", "-screen 0 1280x800x24", env!("CARGO_BIN_EXE_dvsgi"), "view"]).args(args);
    c.current_dir(repo()).env("DVSGI_VALIDATION", "1").env("LP_NUM_THREADS", "4");
    Some(c.output().expect("run xvfb-run"))
}

fn succeeded(o: &Output) -> String {
    let (out, err) = (stdout(o), stderr(o));
    assert!(o.status.success(), "view failed:\n{out}\n{err}");
    assert!(!err.contains("panicked"), "{err}");
    out
}

/// The Cornell box with the `low` preset in a 640x400 window (the image size comes after).
const SMALL: &[&str] =
    &["scenes/cornell-box.toml", "--preset", "low", "--window-width", "640", "--window-height", "400"];

/// The small Cornell box at `size` driven by the script `text` (written into `dir`): its
/// stdout once it has succeeded; `None` where there is no xvfb-run (see [`view`]).
fn run_script(dir: &Path, size: (u32, u32), text: &str) -> Option<String> {
    let (w, h, s) = (size.0.to_string(), size.1.to_string(), script(dir, text));
    let mut args = SMALL.to_vec();
    args.extend(["--width", &w, "--height", &h, "--script", &s]);
    view(&args).map(|o| succeeded(&o))
}

fn script(dir: &Path, text: &str) -> String {
    let p = dir.join("script.txt");
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// The `reproduce:` line's scene file, schedule and frame count.
fn reproduce_line(out: &str) -> (String, String, String) {
    let line = out.lines().find(|l| l.starts_with("reproduce: dvsgi render ")).expect("a reproduce line");
    let w: Vec<&str> = line.split_whitespace().collect();
    (w[3].to_string(), w[5].to_string(), w[7].to_string())
}

#[test]
fn a_capture_is_what_render_makes_of_the_scene_file_it_writes() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("shot");
    let text = format!(
        "pause\nframes 2\ncamera 0.35 0.3 -0.6 0.25 0.25 0.2\nturn 4 -2\nfly 0.2 0.1 0 1\ngi rsm\nframes 2\n\
         schedule sync\ngi vct\nset gi.diffuse_cones=4\nschedule async-pipelined\nframes 3\nschedule async-lagged\nframes 3\n\
         capture {}\nquit\n",
        stem.display()
    );
    let Some(out) = run_script(dir.path(), (96, 64), &text) else { return };
    for suffix in [".png", ".exr", ".toml", "-window.png"] {
        assert!(dir.path().join(format!("shot{suffix}")).is_file(), "no shot{suffix}:\n{out}");
    }
    let window = image::open(dir.path().join("shot-window.png")).unwrap().to_rgb8();
    assert_eq!(window.dimensions(), (640, 400), "the window as shown");
    let (scene, schedule, frames) = reproduce_line(&out);
    assert_eq!((schedule.as_str(), frames.as_str()), ("async-lagged", "7"), "{out}");
    let again = dir.path().join("again.exr");
    let args = ["render", &scene, "--schedule", &schedule, "--frames", &frames, "--out", again.to_str().unwrap()];
    let r = Command::new(env!("CARGO_BIN_EXE_dvsgi"))
        .args(args)
        .current_dir(dir.path())
        .env("DVSGI_VALIDATION", "1")
        .env("LP_NUM_THREADS", "3")
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", stderr(&r));
    let (a, b) = (std::fs::read(stem.with_extension("exr")).unwrap(), std::fs::read(&again).unwrap());
    assert!(a == b, "the capture and `dvsgi render {scene}` differ");
}

#[test]
fn switching_every_technique_and_schedule_keeps_validation_clean_and_memory_flat() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("memory\n");
    let round: String = ["none", "vct", "rsm", "lpv", "rsm+lpv"]
        .iter()
        .flat_map(|gi| {
            ["sync", "async", "async-lagged", "async-pipelined"]
                .iter()
                .map(move |s| format!("gi {gi}\nschedule {s}\nframes 5\n"))
        })
        .collect();
    // A first round brings every pipeline and allocation pool into being; three more must
    // not grow the memory.
    text.push_str(&round);
    text.push_str("memory\n");
    for _ in 0..3 {
        text.push_str(&round);
    }
    text.push_str("memory\nquit\n");
    let Some(out) = run_script(dir.path(), (64, 40), &text) else { return };
    let memory: Vec<(u64, u64)> = out
        .lines()
        .filter(|l| l.starts_with("memory: "))
        .map(|l| {
            let n: Vec<u64> = l.split_whitespace().filter_map(|w| w.parse().ok()).collect();
            (n[0], n[1]) // GPU bytes, resident bytes
        })
        .collect();
    assert_eq!(memory.len(), 3, "{out}");
    let frames = out.lines().find_map(|l| l.strip_prefix("frames: ")).expect("a frames line");
    let frames: u64 = frames.split_whitespace().next().unwrap().parse().unwrap();
    assert!(frames >= 300, "{frames} frames");
    let ((gpu1, rss1), (gpu2, rss2)) = (memory[1], memory[2]);
    // The allocator's total moves by a few bytes of alignment padding as allocations land at
    // other offsets; one leaked renderer would be megabytes, and the rounds rebuild it 45 times.
    assert!(gpu2 <= gpu1 + (1 << 20), "GPU allocations grew from {gpu1} to {gpu2} bytes over 225 frames of switching");
    assert!(rss2 <= rss1 + rss1 / 10, "resident memory grew from {rss1} to {rss2} bytes over 225 frames of switching");
}

#[test]
fn a_window_resized_to_one_pixel_and_back_keeps_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("after");
    let text = format!("frames 2\nresize 1 1\nframes 3\nresize 300 200\nframes 3\ncapture {}\nquit\n", stem.display());
    let Some(out) = run_script(dir.path(), (96, 64), &text) else { return };
    let window = image::open(dir.path().join("after-window.png")).unwrap().to_rgb8();
    assert_eq!(window.dimensions(), (300, 200), "{out}");
}

/// `dvsgi view` with `args` and no display; its stderr, after checking it failed with 1.
fn view_without_display(args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_dvsgi"))
        .arg("view")
        .args(args)
        .current_dir(repo())
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

#[test]
fn without_a_display_the_viewer_says_how_to_get_one() {
    let err = view_without_display(&["scenes/cornell-box.toml"]);
    assert!(err.contains("no display") && err.contains("xvfb-run"), "{err}");
}

#[test]
fn a_bad_script_is_refused_naming_the_file_and_line_before_any_window() {
    let dir = tempfile::tempdir().unwrap();
    let s = script(dir.path(), "frames 2\ncamera 1 2\n");
    let err = view_without_display(&["scenes/cornell-box.toml", "--script", &s]);
    assert!(err.contains("script.txt, line 2") && err.contains("`camera` takes 6 numbers"), "{err}");
}
