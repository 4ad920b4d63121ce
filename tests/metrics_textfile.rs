//! The metrics textfile (`[metrics] textfile`) of a running daemon, read by Prometheus's own
//! text-format parser (`prometheus_client.parser` from the `prometheus-client` package, installed
//! by scripts/setup.sh): written while the daemon runs, every stats interval, and with the final
//! counters after the drain.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Parses the file with `prometheus_client.parser.text_string_to_metric_families` and returns
/// `{family: {"type": ..., "samples": [[name, labels, value], ...]}}`.
fn parse(path: &Path) -> serde_json::Value {
    let script = r#"
import json, sys
from prometheus_client.parser import text_string_to_metric_families
out = {}
for f in text_string_to_metric_families(open(sys.argv[1]).read()):
    out[f.name] = {"type": f.type, "samples": [[s.name, s.labels, s.value] for s in f.samples]}
print(json.dumps(out))
"#;
    let o = Command::new("python3")
        .args(["-c", script])
        .arg(path)
        .output()
        .expect("python3 runs");
    assert!(
        o.status.success(),
        "Prometheus's parser refused {}: {}\n{}",
        path.display(),
        String::from_utf8_lossy(&o.stderr),
        std::fs::read_to_string(path).unwrap_or_default()
    );
    serde_json::from_slice(&o.stdout).unwrap()
}

/// The value of the sample `name` with the labels `labels` (a subset) in family `fam`.
fn value(m: &serde_json::Value, fam: &str, name: &str, labels: &[(&str, &str)]) -> f64 {
    let f = &m[fam];
    f["samples"]
        .as_array()
        .unwrap_or_else(|| panic!("no family {fam} in {m}"))
        .iter()
        .find(|s| s[0] == name && labels.iter().all(|(k, v)| s[1][*k] == *v))
        .unwrap_or_else(|| panic!("no {name} {labels:?} in {f}"))[2]
        .as_f64()
        .unwrap()
}

#[test]
fn a_running_daemon_writes_a_textfile_prometheus_parses() {
    let dir = tempfile::tempdir().unwrap();
    let prom = dir.path().join("mosaicd.prom");
    let cfg = dir.path().join("m.toml");
    std::fs::write(
        &cfg,
        format!(
            "[daemon]\nstats_interval_ms = 100\n[publish]\nenabled = false\n\
             [record]\nenabled = true\npath = {:?}\n[compute]\ndetect = false\n\
             [metrics]\ntextfile = {prom:?}\n\
             [[camera]]\nname = \"live\"\nsource = \"synthetic\"\nwidth = 160\nheight = 120\n\
             fps = 30.0\nframes = 0\nlive = true\n",
            dir.path().join("rec.mcap")
        ),
    )
    .unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(["run", "--config", cfg.to_str().unwrap()])
        .current_dir("/")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // While it runs: the file appears and is rewritten as frames go by.
    let t0 = Instant::now();
    let mut seen = 0.0;
    while seen < 3.0 {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "no metrics file with 3 frames"
        );
        std::thread::sleep(Duration::from_millis(100));
        if prom.exists() {
            let m = parse(&prom);
            seen = value(
                &m,
                "mosaicd_frames_processed",
                "mosaicd_frames_processed_total",
                &[("camera", "live")],
            );
            assert_eq!(m["mosaicd_frames_processed"]["type"], "counter");
            assert_eq!(
                value(
                    &m,
                    "mosaicd_recorder_state",
                    "mosaicd_recorder_state",
                    &[("state", "recording")]
                ),
                1.0,
                "{m}"
            );
        }
    }
    // SIGTERM: drained, then the final counters are written.
    // SAFETY: kill(2) on our own child's pid.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGTERM) }, 0);
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let m = parse(&prom);
    let processed = value(
        &m,
        "mosaicd_frames_processed",
        "mosaicd_frames_processed_total",
        &[("camera", "live")],
    );
    assert!(
        stdout.contains(&format!("camera live: {processed} frames processed of")),
        "the final file ({processed} processed) disagrees with the summary: {stdout}"
    );
    let lat = &m["mosaicd_latency_seconds"];
    assert_eq!(lat["type"], "summary");
    assert_eq!(
        value(
            &m,
            "mosaicd_latency_seconds",
            "mosaicd_latency_seconds_count",
            &[]
        ),
        processed
    );
    let q = |q: &str| {
        value(
            &m,
            "mosaicd_latency_seconds",
            "mosaicd_latency_seconds",
            &[("quantile", q)],
        )
    };
    assert!(
        q("0.5") > 0.0 && q("0.5") <= q("0.99") && q("0.99") <= q("1"),
        "{lat}"
    );
    for reason in ["queue_full", "driver"] {
        value(
            &m,
            "mosaicd_frames_dropped",
            "mosaicd_frames_dropped_total",
            &[("reason", reason)],
        );
    }
    for stage in ["source", "compute", "sink"] {
        assert_eq!(
            value(
                &m,
                "mosaicd_failures",
                "mosaicd_failures_total",
                &[("stage", stage)]
            ),
            0.0
        );
    }
    let state = |s: &str| {
        value(
            &m,
            "mosaicd_recorder_state",
            "mosaicd_recorder_state",
            &[("state", s)],
        )
    };
    assert_eq!(
        (state("finished"), state("recording"), state("off")),
        (1.0, 0.0, 0.0)
    );
    assert_eq!(value(&m, "mosaicd_build_info", "mosaicd_build_info", &[]), 1.0);
    // Only the file: no temporary left beside it.
    let mut names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.contains("prom"))
        .collect();
    names.sort();
    assert_eq!(names, ["mosaicd.prom"]);
}
