//! Fleet metrics without opening a port: the daemon's counters in Prometheus's text exposition
//! format, written to a file for node_exporter's textfile collector (`[metrics] textfile`).
//!
//! Every `daemon.stats_interval_ms`, and once more after the drain, the whole file is rendered
//! ([`render`]) and written atomically ([`write_atomic`]): to a temporary file in the same
//! directory (its name does not end in `.prom`, so the collector never reads it half-written),
//! then renamed over the target. A reader sees the previous file or the new one, never a mix.
//! The file is mode 0644 whatever the service's umask: node_exporter runs as another user.
//!
//! Metrics, each labelled with `camera` (one file for every camera of the daemon):
//!
//! | metric | type | what |
//! |---|---|---|
//! | `mosaicd_frames_captured_total` | counter | frames the source delivered |
//! | `mosaicd_frames_processed_total` | counter | frames computed and handed to the sinks |
//! | `mosaicd_frames_dropped_total{reason}` | counter | `queue_full` (live, oldest dropped), `driver` (sensor sequence gaps) |
//! | `mosaicd_failures_total{stage}` | counter | `source`, `compute`, `sink` errors |
//! | `mosaicd_sink_frames_lost_total` | counter | frames a sink received but did not write |
//! | `mosaicd_detections_total` | counter | boxes found |
//! | `mosaicd_latency_seconds{quantile}` | summary | capture (replay: pipeline entry) to publish, whole run: quantiles 0.5, 0.9, 0.99, 1, `_sum`, `_count` |
//! | `mosaicd_recorder_state{state}` | gauge | 1 for the recorder's state (`off`, `recording`, `paused`, `failed`, `finished`), 0 for the others |
//!
//! and `mosaicd_build_info{version, kernels}` (1) and `mosaicd_start_time_seconds` (Unix time).
//! Quantiles are the latency histogram's bucket bounds (at most 9 % above the true value,
//! [`super::stats::LatencyHistogram`]).
//!
//! ```
//! use mosaicd::pipeline::Stats;
//! use mosaicd::pipeline::render_textfile as render;
//! let s = Stats::default();
//! s.record_latency_ns(2_000_000);
//! let text = render(&[("front", &s)], "0.1.0", "avx2", 1.7e9);
//! assert!(text.contains("mosaicd_frames_processed_total{camera=\"front\"} 0\n"));
//! assert!(text.contains("mosaicd_latency_seconds_count{camera=\"front\"} 1\n"));
//! ```

use std::fmt::Write as _;
use std::io::Write as _;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::stats::{RecorderState, Stats, StatsSnapshot};

/// The latency quantiles written.
pub(crate) const QUANTILES: [f64; 4] = [0.5, 0.9, 0.99, 1.0];

/// Mode of the written file: readable by node_exporter's user.
const FILE_MODE: u32 = 0o644;

/// A label value with `\`, `"` and newlines escaped, as the text format wants.
fn escape(v: &str) -> String {
    v.replace('\\', r"\\").replace('"', "\\\"").replace('\n', r"\n")
}

/// One metric family: `# HELP`, `# TYPE`, then `samples` (name suffix, extra labels, value) for
/// every camera.
fn family(
    out: &mut String,
    name: &str,
    typ: &str,
    help: &str,
    cams: &[(&str, &Stats)],
    samples: impl Fn(&Stats) -> Vec<(&'static str, String, f64)>,
) {
    let _ = writeln!(out, "# HELP {name} {help}");
    let _ = writeln!(out, "# TYPE {name} {typ}");
    for (cam, s) in cams {
        for (suffix, labels, v) in samples(s) {
            let _ = writeln!(out, "{name}{suffix}{{camera=\"{}\"{labels}}} {v}", escape(cam));
        }
    }
}

/// The text of the metrics file for `cams` (name, counters).
pub fn render(cams: &[(&str, &Stats)], version: &str, kernels: &str, start_time_s: f64) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "# HELP mosaicd_build_info The daemon's version and kernel path."
    );
    let _ = writeln!(o, "# TYPE mosaicd_build_info gauge");
    let _ = writeln!(
        o,
        "mosaicd_build_info{{version=\"{}\",kernels=\"{}\"}} 1",
        escape(version),
        escape(kernels)
    );
    let _ = writeln!(
        o,
        "# HELP mosaicd_start_time_seconds When the daemon started, Unix time."
    );
    let _ = writeln!(o, "# TYPE mosaicd_start_time_seconds gauge");
    let _ = writeln!(o, "mosaicd_start_time_seconds {start_time_s}");
    // The counters: name, help, and each sample's extra label ("" for none) and value.
    type Samples = fn(&StatsSnapshot) -> Vec<(&'static str, u64)>;
    let counters: [(&str, &str, Samples); 6] = [
        (
            "mosaicd_frames_captured_total",
            "Frames the source delivered.",
            |s| vec![("", s.captured)],
        ),
        (
            "mosaicd_frames_processed_total",
            "Frames computed and handed to the sinks.",
            |s| vec![("", s.processed)],
        ),
        (
            "mosaicd_frames_dropped_total",
            "Frames dropped, by reason: queue_full (a live camera's oldest frame when compute falls behind), driver (sensor sequence gaps).",
            |s| vec![("reason=\"queue_full\"", s.dropped_queue_full), ("reason=\"driver\"", s.dropped_driver)],
        ),
        (
            "mosaicd_failures_total",
            "Errors, by stage: source (a frame or file that could not be read), compute, sink (publish or record).",
            |s| {
                vec![
                    ("stage=\"source\"", s.failed_source),
                    ("stage=\"compute\"", s.failed_compute),
                    ("stage=\"sink\"", s.failed_sink),
                ]
            },
        ),
        (
            "mosaicd_sink_frames_lost_total",
            "Frames a sink received but did not write (a recording paused or stopped by a write error).",
            |s| vec![("", s.sink_frames_lost)],
        ),
        (
            "mosaicd_detections_total",
            "Pedestrian boxes found.",
            |s| vec![("", s.detections)],
        ),
    ];
    for (name, help, samples) in counters {
        family(&mut o, name, "counter", help, cams, |s| {
            samples(&s.snapshot())
                .into_iter()
                .map(|(label, v)| {
                    let label = if label.is_empty() {
                        String::new()
                    } else {
                        format!(",{label}")
                    };
                    ("", label, v as f64)
                })
                .collect()
        });
    }
    family(
        &mut o,
        "mosaicd_latency_seconds",
        "summary",
        "Capture (replay: pipeline entry) to publish latency over the whole run; quantiles are histogram bucket bounds (at most 9 % high).",
        cams,
        |s| {
            let l = s.latency_summary(&QUANTILES);
            let mut v: Vec<_> = l
                .quantiles
                .iter()
                .map(|&(q, secs)| ("", format!(",quantile=\"{q}\""), secs))
                .collect();
            v.push(("_sum", String::new(), l.sum_s));
            v.push(("_count", String::new(), l.count as f64));
            v
        },
    );
    family(
        &mut o,
        "mosaicd_recorder_state",
        "gauge",
        "1 for the MCAP recorder's state: off (not enabled), recording, paused (write error, retrying), failed (stopped for the run), finished.",
        cams,
        |s| {
            let now = s.recorder_state();
            RecorderState::ALL
                .iter()
                .map(|&st| ("", format!(",state=\"{}\"", st.name()), (st == now) as u8 as f64))
                .collect()
        },
    );
    o
}

/// Writes `text` to `path` atomically: a temporary file beside it (`.<name>.tmp`, which
/// node_exporter ignores), mode 0644, renamed over `path`.
pub(crate) fn write_atomic(path: &Path, text: &str) -> std::io::Result<()> {
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "the metrics path has no file name",
        )
    })?;
    let tmp = path.with_file_name(format!(".{}.tmp", name.to_string_lossy()));
    let written = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(text.as_bytes())?;
        // chmod is not masked by the umask (the units' 0027 would hide the file from the collector).
        f.set_permissions(std::fs::Permissions::from_mode(FILE_MODE))?;
        std::fs::rename(&tmp, path)
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// The daemon's metrics file: the cameras' shared counters and where to write them.
pub(crate) struct Textfile {
    path: PathBuf,
    cameras: Vec<(String, Arc<Stats>)>,
    start_time_s: f64,
    /// The last write failed (logged once until a write succeeds again).
    failing: bool,
}

impl Textfile {
    /// A writer for `path` over the cameras' counters.
    pub(crate) fn new(path: PathBuf, cameras: Vec<(String, Arc<Stats>)>) -> Self {
        let start_time_s = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0);
        Self {
            path,
            cameras,
            start_time_s,
            failing: false,
        }
    }

    /// Renders and writes the file. A failure is logged (once until it works again) and never
    /// stops the daemon.
    pub(crate) fn write(&mut self) {
        let cams: Vec<(&str, &Stats)> = self.cameras.iter().map(|(c, s)| (c.as_str(), &**s)).collect();
        let text = render(
            &cams,
            env!("CARGO_PKG_VERSION"),
            crate::kernels::isa().name(),
            self.start_time_s,
        );
        match write_atomic(&self.path, &text) {
            Ok(()) if self.failing => {
                self.failing = false;
                tracing::info!(file = %self.path.display(), "metrics textfile written again");
            }
            Ok(()) => {}
            Err(e) if !self.failing => {
                self.failing = true;
                tracing::warn!(file = %self.path.display(), "cannot write the metrics textfile (metrics.textfile): {e}; trying again every stats interval");
            }
            Err(_) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_family_has_help_type_and_one_sample_set_per_camera() {
        let a = Stats::default();
        let b = Stats::default();
        Stats::inc(&a.processed);
        Stats::inc(&a.dropped_queue_full);
        b.set_recorder_state(RecorderState::Paused);
        for ms in [1, 2, 3] {
            a.record_latency_ns(ms * 1_000_000);
        }
        let t = render(&[("a", &a), ("b", &b)], "9.9.9", "scalar", 10.5);
        for line in [
            "mosaicd_build_info{version=\"9.9.9\",kernels=\"scalar\"} 1",
            "mosaicd_start_time_seconds 10.5",
            "mosaicd_frames_processed_total{camera=\"a\"} 1",
            "mosaicd_frames_processed_total{camera=\"b\"} 0",
            "mosaicd_frames_dropped_total{camera=\"a\",reason=\"queue_full\"} 1",
            "mosaicd_frames_dropped_total{camera=\"a\",reason=\"driver\"} 0",
            "mosaicd_failures_total{camera=\"b\",stage=\"sink\"} 0",
            "mosaicd_latency_seconds_count{camera=\"a\"} 3",
            "mosaicd_latency_seconds_sum{camera=\"a\"} 0.006",
            "mosaicd_recorder_state{camera=\"a\",state=\"off\"} 1",
            "mosaicd_recorder_state{camera=\"b\",state=\"paused\"} 1",
            "mosaicd_recorder_state{camera=\"b\",state=\"off\"} 0",
        ] {
            assert!(t.lines().any(|l| l == line), "{line:?} not in\n{t}");
        }
        // the median of 1, 2, 3 ms: the bucket bound above 2 ms
        let p50: f64 = t
            .lines()
            .find(|l| l.starts_with("mosaicd_latency_seconds{camera=\"a\",quantile=\"0.5\"}"))
            .and_then(|l| l.rsplit(' ').next())
            .unwrap()
            .parse()
            .unwrap();
        assert!((0.002..=0.002 * 1.091).contains(&p50), "{p50}");
        for fam in [
            "mosaicd_frames_captured_total",
            "mosaicd_latency_seconds",
            "mosaicd_recorder_state",
        ] {
            assert_eq!(t.matches(&format!("# TYPE {fam} ")).count(), 1, "{fam}");
            assert_eq!(t.matches(&format!("# HELP {fam} ")).count(), 1, "{fam}");
        }
        assert_eq!(escape("a\"b\\c\nd"), "a\\\"b\\\\c\\nd");
    }

    #[test]
    fn the_file_is_replaced_whole_with_mode_0644_and_no_temporary_left() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("mosaicd.prom");
        write_atomic(&p, "old\n").unwrap();
        write_atomic(&p, "new\n").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new\n");
        assert_eq!(std::fs::metadata(&p).unwrap().permissions().mode() & 0o777, 0o644);
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("mosaicd.prom")]);
        // A directory that does not exist: an error, no file.
        assert!(write_atomic(&dir.path().join("no/mosaicd.prom"), "x").is_err());
    }
}
