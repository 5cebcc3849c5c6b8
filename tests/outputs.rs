//! A file the user already has at an output path survives a failed write, byte for byte: a
//! full disk (a tiny tmpfs: writes past it fail with ENOSPC), a sibling output that fails
//! (at its write, or at its rename), and `kill -9` at any moment of a large EXR write, which
//! must leave either the old file or the complete new one, never a truncated one. Each runs the
//! real `dvsgi` binary. Before `src/output.rs` wrote to temporaries and renamed them, each of
//! these tests failed (checked by making `write_synced` write straight to the target).

mod common;
use common::{repo, stderr, stdout};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The `dvsgi` binary from the repository root, validation on.
fn dvsgi_command() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_dvsgi"));
    c.current_dir(repo()).env("DVSGI_VALIDATION", "1");
    c
}

/// The outputs' directory on a full disk: a tmpfs of `KIB` KiB mounted in a user and mount
/// namespace of its own (`unshare -rm`: any user where unprivileged user namespaces are on,
/// as on Debian and Ubuntu), seeded with `files`. `dvsgi` runs there with `args(dir)`, and the
/// directory's contents after the run are copied out, since the mount ends with the namespace.
/// None (the test is skipped, saying why) where the namespace cannot be made. A file-size
/// limit (`ulimit -f`) cannot stand in for the full disk: Mesa 25's lavapipe backs device
/// memory with memfd files, which the limit also caps (the process dies of SIGBUS).
fn dvsgi_on_a_full_disk(
    files: &[(&str, &[u8])],
    args: impl Fn(&Path) -> Vec<String>,
) -> Option<(Output, tempfile::TempDir)> {
    let probe = Command::new("unshare").args(["-rm", "true"]).stderr(Stdio::null()).status();
    if !probe.is_ok_and(|s| s.success()) {
        eprintln!("skipped: `unshare -rm` (a user and mount namespace for a tmpfs) is not available here");
        return None;
    }
    let (seed, mount, snapshot) =
        (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for (name, bytes) in files {
        std::fs::write(seed.path().join(name), bytes).unwrap();
    }
    let script = "mount -t tmpfs -o size=\"$0\"k tmpfs \"$1\" && cp -a \"$2\"/. \"$1\"/ || exit 97
        shift 2; \"$@\"; rc=$?; cp -a \"$D\"/. \"$S\"/ || exit 97; exit $rc";
    let o = Command::new("unshare")
        .args(["-rm", "sh", "-c", script])
        .arg(FULL_DISK_KIB.to_string())
        .arg(mount.path())
        .arg(seed.path())
        .arg(env!("CARGO_BIN_EXE_dvsgi"))
        .args(args(mount.path()))
        .env("D", mount.path())
        .env("S", snapshot.path())
        .current_dir(repo())
        .env("DVSGI_VALIDATION", "1")
        .output()
        .expect("run unshare");
    assert_ne!(o.status.code(), Some(97), "could not mount the tmpfs:\n{}", stderr(&o));
    Some((o, snapshot))
}

/// `render` of the Cornell box, direct light only, `size`², to every `out`.
fn render_args(size: u32, out: &[&Path]) -> Vec<String> {
    let size = size.to_string();
    let mut args: Vec<String> =
        ["render", "scenes/cornell-box.toml", "--gi", "none", "--width", &size, "--height", &size]
            .iter()
            .map(|s| s.to_string())
            .collect();
    for o in out {
        args.extend(["--out".to_string(), o.to_str().unwrap().to_string()]);
    }
    args
}

/// The full disk: 96 KiB. The old EXR (48 KB), an old PNG and a 128² render's new PNG (14 KB)
/// fit; its EXR (160 KB) does not.
const FULL_DISK_KIB: u64 = 96;
const SIZE: u32 = 128;

/// A user's earlier EXR (a radiance image from the repository).
fn old_exr() -> Vec<u8> {
    std::fs::read(repo().join("tests/data/cornell-64.exr")).unwrap()
}

/// A user's earlier PNG: an 8×8 gradient.
fn old_png(path: &Path) -> Vec<u8> {
    let img = image::RgbImage::from_fn(8, 8, |x, y| image::Rgb([(x * 32) as u8, (y * 32) as u8, 128]));
    dvsgi::output::encode_png(path, &img).unwrap()
}

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

fn assert_intact(path: &Path, old: &[u8], what: &str) {
    let now = std::fs::read(path).unwrap_or_else(|e| panic!("{what}: {} is gone: {e}", path.display()));
    assert!(
        now == old,
        "{what}: {} changed: {} bytes now, {} before{}",
        path.display(),
        now.len(),
        old.len(),
        if now.len() < old.len() { " (truncated)" } else { "" }
    );
}

/// A full disk: the new EXR does not fit on it, the write fails, and the EXR already at the
/// output path is unchanged, with nothing else left in its directory.
#[test]
fn a_full_disk_leaves_the_old_file_intact() {
    let old = old_exr();
    let Some((o, after)) = dvsgi_on_a_full_disk(&[("x.exr", &old)], |d| render_args(SIZE, &[&d.join("x.exr")])) else {
        return;
    };
    let err = stderr(&o);
    assert!(!o.status.success(), "the write to a full disk must fail:\n{}{err}", stdout(&o));
    assert!(err.contains("x.exr") && err.contains("No space left on device"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_intact(&after.path().join("x.exr"), &old, "full disk");
    assert_eq!(names(after.path()), ["x.exr"], "a temporary file is left");
    // With room the same command replaces the file with a larger one: the full disk is what
    // failed it.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    std::fs::write(&out, &old).unwrap();
    let o = dvsgi_command().args(render_args(SIZE, &[&out])).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let new = std::fs::read(&out).unwrap();
    assert!(new != old && new.len() as u64 > FULL_DISK_KIB * 1024, "new EXR: {} bytes", new.len());
}

/// Two outputs, the second of which fails at its write (the PNG fits on the disk, the EXR
/// does not): the command writes all or none, so the first output's old file is unchanged too.
#[test]
fn a_sibling_output_that_fails_to_write_leaves_every_old_file_intact() {
    let (old_p, old_e) = (old_png(Path::new("x.png")), old_exr());
    let files: [(&str, &[u8]); 2] = [("x.png", &old_p), ("y.exr", &old_e)];
    let both = |d: &Path| render_args(SIZE, &[&d.join("x.png"), &d.join("y.exr")]);
    let Some((o, after)) = dvsgi_on_a_full_disk(&files, both) else { return };
    let err = stderr(&o);
    assert!(!o.status.success(), "{}{err}", stdout(&o));
    assert!(err.contains("y.exr") && err.contains("No space left on device"), "{err}");
    assert_intact(&after.path().join("x.png"), &old_p, "the PNG beside a failed EXR");
    assert_intact(&after.path().join("y.exr"), &old_e, "the failed EXR");
    assert_eq!(names(after.path()), ["x.png", "y.exr"], "a temporary file is left");
    // The PNG alone fits on the same disk: it was the EXR that failed.
    let (o, after) = dvsgi_on_a_full_disk(&files, |d| render_args(SIZE, &[&d.join("x.png")])).unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read(after.path().join("x.png")).unwrap() != old_p, "the PNG was rewritten");
}

/// An immutable file (`chattr +i`): even root can neither replace nor remove it. Removes the
/// flag again on drop, so the temporary directory can go.
struct Immutable(PathBuf);

impl Immutable {
    fn new(path: &Path) -> Option<Immutable> {
        let ok = Command::new("chattr").arg("+i").arg(path).stderr(Stdio::null()).status().is_ok_and(|s| s.success());
        if !ok {
            eprintln!("skipped: chattr +i needs root and a file system with the immutable flag (ext4, xfs, btrfs)");
            return None;
        }
        Some(Immutable(path.to_path_buf()))
    }
}

impl Drop for Immutable {
    fn drop(&mut self) {
        let _ = Command::new("chattr").arg("-i").arg(&self.0).status();
    }
}

/// Two outputs, the second of which cannot be replaced: an immutable file (root too gets
/// EPERM), which passes the up-front check (its directory is writable) and fails only at its
/// rename, after the first output's rename. The first output's old file must come back. And a
/// second output whose directory is a file is refused before any work, the first untouched.
#[test]
fn a_sibling_output_that_cannot_be_replaced_leaves_every_old_file_intact() {
    let dir = tempfile::tempdir().unwrap();
    let (png, exr) = (dir.path().join("x.png"), dir.path().join("y.exr"));
    let (old_p, old_e) = (old_png(&png), old_exr());
    std::fs::write(&png, &old_p).unwrap();
    std::fs::write(&exr, &old_e).unwrap();
    // A path whose parent is a file: refused up front (ENOTDIR, root included).
    let under_file = dir.path().join("y.exr/z.exr");
    let o = dvsgi_command().args(render_args(16, &[&png, &under_file])).output().unwrap();
    assert!(!o.status.success() && stderr(&o).contains("z.exr"), "{}", stderr(&o));
    assert_intact(&png, &old_p, "beside an output under a file");
    assert_eq!(names(dir.path()), ["x.png", "y.exr"], "a file is left");
    // The new PNG with no old one there: it must be gone again after the failure.
    let fresh = dir.path().join("w.png");
    {
        let Some(_guard) = Immutable::new(&exr) else { return };
        let o = dvsgi_command().args(render_args(16, &[&png, &fresh, &exr])).output().unwrap();
        let err = stderr(&o);
        assert!(!o.status.success(), "replacing an immutable file must fail:\n{}{err}", stdout(&o));
        assert!(err.contains("y.exr") && err.contains("not permitted"), "{err}");
        assert!(!err.contains("panicked"), "{err}");
        assert_intact(&png, &old_p, "the PNG renamed before the failed EXR");
        assert_intact(&exr, &old_e, "the immutable EXR");
        assert!(!fresh.exists(), "w.png was written although y.exr failed");
        assert_eq!(names(dir.path()), ["x.png", "y.exr"], "a temporary or backup file is left");
    }
    // Once the flag is gone the same command writes all three.
    let o = dvsgi_command().args(render_args(16, &[&png, &fresh, &exr])).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read(&png).unwrap() != old_p && fresh.exists() && std::fs::read(&exr).unwrap() != old_e);
    assert_eq!(names(dir.path()), ["w.png", "x.png", "y.exr"]);
}

/// `kill -9` while a 2048² EXR (39 MB) is written over an old one, at several moments from
/// the first sign of the write (a temporary with data beside the target, or the target itself
/// changing) on: afterwards the target holds the old bytes or a complete EXR that decodes at
/// full size, never a truncated file. A killed process may leave its temporary behind (it
/// cannot remove it); its name must be a hidden `.x.exr.PID.tmp` (or `.PID.old.tmp`), never
/// one a user would take for an output.
#[test]
fn kill_9_during_a_large_exr_write_leaves_the_old_file_or_the_new_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    let old = old_exr();
    let args = render_args(2048, &[&out]);
    let mut outcomes = Vec::new();
    for delay_ms in [0u64, 3, 10, 30, 60, 100] {
        std::fs::write(&out, &old).unwrap();
        let ino = std::os::unix::fs::MetadataExt::ino(&std::fs::metadata(&out).unwrap());
        let mut child =
            dvsgi_command().args(&args).stdout(Stdio::null()).stderr(Stdio::null()).spawn().expect("spawn dvsgi");
        let start = Instant::now();
        // Poll for the write: a temporary with data in it (the writability probes are empty),
        // or the target no longer the old file.
        let began = loop {
            let target_changed = std::fs::metadata(&out)
                .map(|m| std::os::unix::fs::MetadataExt::ino(&m) != ino || m.len() != old.len() as u64)
                .unwrap_or(true);
            let temp_with_data = std::fs::read_dir(dir.path()).unwrap().any(|e| {
                let e = e.unwrap();
                e.file_name() != "x.exr" && e.metadata().is_ok_and(|m| m.len() > 0)
            });
            if target_changed || temp_with_data {
                break true;
            }
            if child.try_wait().unwrap().is_some() || start.elapsed() > Duration::from_secs(60) {
                break false;
            }
            std::thread::sleep(Duration::from_micros(200));
        };
        assert!(began, "delay {delay_ms} ms: the write was never seen");
        std::thread::sleep(Duration::from_millis(delay_ms));
        let exited_before = child.try_wait().unwrap().is_some();
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        let now = std::fs::read(&out).unwrap_or_default();
        let outcome = if now == old {
            "old file"
        } else {
            match dvsgi::output::read_rgb_f32(&out) {
                Ok(img) if (img.width, img.height) == (2048, 2048) => "new file",
                Ok(img) => panic!("delay {delay_ms} ms: x.exr is {}x{}, not 2048x2048", img.width, img.height),
                Err(e) => panic!(
                    "delay {delay_ms} ms: x.exr is neither the old file nor a complete EXR ({} bytes): {e}",
                    now.len()
                ),
            }
        };
        let left: Vec<String> = names(dir.path()).into_iter().filter(|n| n != "x.exr").collect();
        let mut left_sizes = Vec::new();
        for n in &left {
            let hidden_tmp = n.starts_with(".x.exr.") && n.ends_with(".tmp");
            assert!(hidden_tmp, "delay {delay_ms} ms: a file a user could mistake for an output is left: {n}");
            left_sizes.push(std::fs::metadata(dir.path().join(n)).unwrap().len());
            std::fs::remove_file(dir.path().join(n)).unwrap();
        }
        eprintln!(
            "kill -9 {delay_ms} ms after the write began ({:.0} ms after the start{}): {outcome}, left behind {left:?} \
             ({left_sizes:?} bytes)",
            start.elapsed().as_secs_f64() * 1e3,
            if exited_before { ", it had already exited" } else { "" }
        );
        outcomes.push((outcome, left.len()));
    }
    // The kills must have landed inside the write at least once (a temporary left behind and
    // the old file in place), or this test tried nothing.
    assert!(
        outcomes.iter().any(|&(o, left)| o == "old file" && left > 0),
        "no kill landed while the temporary was being written: {outcomes:?}"
    );
}
