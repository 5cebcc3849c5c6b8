//! The cross-family async path on lavapipe: the queue-splitting layer (tools/split-queues,
//! run by tools/with-split-queues.sh) shows the one queue as a graphics family and a separate
//! compute-only family, with the validation layer above it. These tests run the `dvsgi` binary
//! under it; tools/test.sh also runs the schedule tests in-process under it.

mod common;
use common::{dvsgi_split, stderr, stdout};
use std::collections::HashMap;

#[test]
fn info_reports_the_dedicated_compute_family() {
    let o = dvsgi_split(&["info"], &[]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}{out}", stderr(&o));
    // The virtual compute-only family carries the real family's SPARSE_BINDING (Mesa 25's
    // lavapipe has it; Mesa 22's has not), as NVIDIA's compute-only family does: both run
    // on the one real queue, which can bind sparse memory.
    let families = out.lines().skip_while(|l| !l.contains("queue families:"));
    let family = |i: u32| families.clone().find(|l| l.trim_start().starts_with(&format!("[{i}] "))).unwrap_or("");
    let sparse = family(0).contains("SPARSE_BINDING");
    let expected = if sparse { "[1] COMPUTE | TRANSFER | SPARSE_BINDING x1" } else { "[1] COMPUTE | TRANSFER x1" };
    assert!(family(1).trim_start().starts_with(expected), "{out}");
    assert!(family(0).contains("GRAPHICS") && !family(1).contains("GRAPHICS"), "{out}");
    assert!(out.contains("compute queue: family 1 index 0"), "{out}");
    assert!(out.contains("dedicated compute-only family"), "{out}");
}

/// One `vkQueueSubmit2` batch: its queue and the timeline values it signals and waits for.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Submit {
    queue: String,
    signal: u64,
    wait: Option<u64>,
}

/// The frame's submits as the layer saw them handed to `vkQueueSubmit2`
/// (`DVSGI_SPLIT_QUEUES_TRACE`): load-time uploads signal nothing and are left out.
fn handed_submits(trace: &str) -> Vec<Submit> {
    let field = |line: &str, name: &str| -> Vec<(String, u64)> {
        let v = line.split_whitespace().find_map(|w| w.strip_prefix(name)).expect("trace field");
        v.split(',')
            .filter(|s| !s.is_empty())
            .map(|p| {
                let (sem, value) = p.split_once(':').expect("SEM:VALUE");
                (sem.to_string(), value.parse().expect("value"))
            })
            .collect()
    };
    let lines: Vec<(u32, Vec<(String, u64)>, Vec<(String, u64)>)> = trace
        .lines()
        .map(|l| {
            let fam: u32 = l.split_whitespace().find_map(|w| w.strip_prefix("family=")).unwrap().parse().unwrap();
            (fam, field(l, "waits="), field(l, "signals="))
        })
        .filter(|(_, _, signals)| !signals.is_empty())
        .collect();
    // Each family signals its own timeline.
    let mut timeline: HashMap<String, u32> = HashMap::new();
    for (fam, _, signals) in &lines {
        for (sem, _) in signals {
            let prev = timeline.insert(sem.clone(), *fam);
            assert!(prev.is_none() || prev == Some(*fam), "a timeline signalled from both queues: {trace}");
        }
    }
    let name = |f: u32| if f == 0 { "graphics" } else { "compute" }.to_string();
    lines
        .iter()
        .map(|(fam, waits, signals)| {
            assert_eq!(signals.len(), 1, "{trace}");
            assert!(
                waits.iter().all(|(sem, _)| timeline.get(sem) == Some(&(1 - fam))),
                "waits on the other queue only"
            );
            Submit { queue: name(*fam), signal: signals[0].1, wait: waits.iter().map(|w| w.1).max() }
        })
        .collect()
}

/// The submits `render -v` reports: `  submit QUEUE SIGNAL[, waits for OTHER VALUE]: passes`.
fn reported_submits(out: &str) -> Vec<Submit> {
    out.lines()
        .filter_map(|l| l.trim_start().strip_prefix("submit "))
        .map(|l| {
            let head = l.split(':').next().unwrap();
            let mut parts = head.split(", waits for ");
            let mut q = parts.next().unwrap().split_whitespace();
            let queue = q.next().unwrap().to_string();
            let signal = q.next().unwrap().parse().unwrap();
            let wait = parts.next().map(|w| w.split_whitespace().nth(1).unwrap().parse().unwrap());
            Submit { queue, signal, wait }
        })
        .collect()
}

/// `(pass, resource, from, to)` of each `release`/`acquire` line of `render -v`.
fn transfers(out: &str, kind: &str) -> Vec<(String, String, String, String)> {
    let mut v: Vec<_> = out
        .lines()
        .filter_map(|l| {
            let rest = l.trim_start().strip_prefix("before ")?;
            let (pass, rest) = rest.split_once(" (")?;
            let (_, rest) = rest.split_once("): ")?;
            let (res, rest) = rest.split_once(": ")?;
            let rest = rest.strip_prefix(kind)?.trim_start();
            let mut w = rest.split_whitespace();
            let (from, _, to) = (w.next()?, w.next()?, w.next()?);
            Some((pass.to_string(), res.to_string(), from.to_string(), to.to_string()))
        })
        .collect();
    v.sort();
    v
}

#[test]
fn async_frames_transfer_ownership_and_wait_as_reported_in_any_queue_order() {
    let dir = tempfile::tempdir().unwrap();
    let mut reference: Option<Vec<u8>> = None;
    for order in ["submission", "compute-first", "graphics-first"] {
        for mode in ["sync", "async", "async-lagged", "async-pipelined"] {
            let png = dir.path().join(format!("{order}-{mode}.png"));
            let trace = dir.path().join(format!("{order}-{mode}.trace"));
            let o = dvsgi_split(
                &[
                    "render",
                    "scenes/cornell-glossy.toml",
                    "--set",
                    "gi.voxel_resolution=16",
                    "--width",
                    "32",
                    "--height",
                    "32",
                    "--schedule",
                    mode,
                    "-v",
                    "--out",
                    png.to_str().unwrap(),
                ],
                &[("DVSGI_SPLIT_QUEUES_ORDER", order), ("DVSGI_SPLIT_QUEUES_TRACE", trace.to_str().unwrap())],
            );
            let (out, err) = (stdout(&o), stderr(&o));
            let what = format!("{order} {mode}");
            assert!(o.status.success(), "{what}: {err}");
            assert!(!err.contains("validation"), "{what}: {err}");
            if mode != "sync" {
                assert!(out.contains("dedicated compute-only family"), "{what}: {out}");
            }
            // Ownership: every release has its acquire before the same pass; sync has none.
            let (releases, acquires) = (transfers(&out, "release"), transfers(&out, "acquire"));
            assert_eq!(releases, acquires, "{what}: release/acquire pairs");
            assert_eq!(releases.is_empty(), mode == "sync", "{what}: {releases:?}");
            // The waits handed to vkQueueSubmit2 (seen below the validation layer) are the
            // ones the scheduler reports.
            let handed = handed_submits(&std::fs::read_to_string(&trace).unwrap());
            assert_eq!(handed, reported_submits(&out), "{what}");
            if mode != "sync" {
                assert!(handed.iter().any(|s| s.queue == "compute" && s.wait.is_some()), "{what}: {handed:?}");
                let last = handed.last().unwrap();
                if mode == "async-pipelined" {
                    // The tail (lighting, tone map, read-back copies) runs on compute.
                    assert!(last.queue == "compute" && last.wait.is_some(), "{what}: the frame ends on compute");
                } else {
                    assert!(
                        last.queue == "graphics" && last.wait.is_some(),
                        "{what}: the frame ends waiting for compute"
                    );
                }
            }
            // Whatever order the two queues run in, the image is the same.
            let bytes = std::fs::read(&png).unwrap();
            match &reference {
                None => reference = Some(bytes),
                Some(r) => assert!(r == &bytes, "{what}: image differs from sync in submission order"),
            }
        }
    }
}

#[test]
fn a_bad_queue_order_is_refused_by_name() {
    let o = dvsgi_split(&["info"], &[("DVSGI_SPLIT_QUEUES_ORDER", "sideways")]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("DVSGI_SPLIT_QUEUES_ORDER") && err.contains("compute-first"), "{err}");
}
