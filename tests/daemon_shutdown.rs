//! Shutdown always ends within `daemon.shutdown_timeout_ms`, as real processes: a paced replay
//! whose timestamps jump by centuries, SIGTERM in the middle of a paced wait, and SIGTERM while a
//! sink is stuck in a write. Recordings that can be finished are (they end with the MCAP magic
//! after their footer and open again).

use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use mosaicd::capture::{McapSource, McapSourceOptions, Source};
use mosaicd::raw::{Cfa, FrameMeta, Levels, RawFrame};
use mosaicd::record::{McapRecorder, RecorderOptions};

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");

/// A recording of 16x16 frames stamped `timestamps`.
fn recording(dir: &Path, timestamps: &[u64]) -> PathBuf {
    let path = dir.join("in.mcap");
    let mut rec = McapRecorder::create(&path, RecorderOptions::default()).unwrap();
    for (i, &t) in timestamps.iter().enumerate() {
        let f = RawFrame::from_u8(
            16,
            16,
            vec![(i * 40) as u8; 256],
            Cfa::Rggb,
            Levels::uniform(0, 255),
        )
        .unwrap()
        .with_meta(FrameMeta {
            sequence: i as u64,
            timestamp_ns: t,
            ..Default::default()
        });
        rec.write_frame(&f).unwrap();
    }
    rec.finish().unwrap();
    path
}

fn replay_config(dir: &Path, timeout_ms: u64) -> PathBuf {
    let p = dir.join("replay.toml");
    std::fs::write(
        &p,
        format!(
            "[daemon]\nthreads = 1\nshutdown_timeout_ms = {timeout_ms}\n[compute]\ndetect = false\n\
             [publish]\nenabled = false\n[[camera]]\nname = \"x\"\nsource = \"synthetic\"\n"
        ),
    )
    .unwrap();
    p
}

/// `mosaicd replay --realtime` of `input` into `out` (stderr piped).
fn realtime_replay(dir: &Path, input: &Path, out: &Path) -> Child {
    Command::new(BIN)
        .args(["replay", "--realtime", "--out"])
        .arg(out)
        .arg("--config")
        .arg(replay_config(dir, 5000))
        .arg(input)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// After `wait` (the child must still be running then when `running`), SIGTERM the child and
/// wait for it up to `limit` (killed, and the test fails, when it is still running): its status,
/// the time it took to leave after the signal, and its stderr.
fn sigterm_after(
    child: &mut Child,
    wait: Duration,
    running: bool,
    limit: Duration,
) -> (ExitStatus, Duration, String) {
    std::thread::sleep(wait);
    if running {
        assert!(child.try_wait().unwrap().is_none(), "ended before the signal");
    }
    let term = Instant::now();
    // SAFETY: plain kill(2) on our own child's pid.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if term.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("still running {limit:?} after SIGTERM");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let left = term.elapsed();
    let mut err = String::new();
    use std::io::Read;
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    (status, left, err)
}

/// The file is a finished MCAP (footer and closing magic) whose raw frames all read back.
fn assert_finished_mcap(path: &Path) -> u64 {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        bytes.len() > 16 && bytes[bytes.len() - 8..] == mcap::MAGIC[..],
        "{}: {} bytes, no closing magic: not finished",
        path.display(),
        bytes.len()
    );
    let summary = mosaicd::wire::read_summary(&mut std::io::Cursor::new(&bytes))
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .unwrap_or_else(|| panic!("{}: no summary", path.display()));
    summary.stats.map_or(0, |s| s.message_count)
}

#[test]
fn a_realtime_replay_over_a_centuries_long_gap_ends_promptly_with_a_finished_recording() {
    let dir = tempfile::tempdir().unwrap();
    let input = recording(dir.path(), &[0, u64::MAX, 5]);
    let out = dir.path().join("out.mcap");
    let t0 = Instant::now();
    let mut child = realtime_replay(dir.path(), &input, &out);
    // The reproduction: SIGTERM a second in (the replay may have ended by itself: the jump
    // is not slept through).
    let (status, _, err) = sigterm_after(&mut child, Duration::from_secs(1), false, Duration::from_secs(10));
    assert!(t0.elapsed() < Duration::from_secs(8), "took {:?}", t0.elapsed());
    assert!(status.success(), "{status}: {err}");
    assert!(err.contains("timestamps jump"), "the jump is logged: {err}");
    // Every frame's results (three frames, none waited for) and the final stats.
    assert!(assert_finished_mcap(&out) >= 4);
}

#[test]
fn pacing_counts_jumps_and_does_not_sleep_through_them() {
    use mosaicd::capture::{FakeClock, Pacing};
    use std::sync::Arc;
    let dir = tempfile::tempdir().unwrap();
    let s = 1_000_000_000u64;
    let input = recording(dir.path(), &[0, s, u64::MAX, 5, 5 + s, 5 + 30 * s]);
    let clock = Arc::new(FakeClock::new(0));
    let mut src = McapSource::open(
        &input,
        McapSourceOptions {
            pacing: Pacing::Recorded { speed: 1.0 },
            clock: clock.clone(),
            ..Default::default()
        },
    )
    .unwrap();
    while src.next_frame().unwrap().is_some() {}
    // Waited: 0 -> 1 s, and 5 -> 5 + 1 s; jumps: to u64::MAX, back to 5, and the 30 s step.
    assert_eq!(src.pacing_jumps(), 3);
    assert_eq!(clock.slept_ns(), 2 * s);
}

#[test]
fn sigterm_during_a_paced_wait_ends_it_at_once() {
    let dir = tempfile::tempdir().unwrap();
    // 9 s between the frames: under the 10 s jump limit, so the source waits for it.
    let input = recording(dir.path(), &[0, 9_000_000_000]);
    let out = dir.path().join("out.mcap");
    let t0 = Instant::now();
    let mut child = realtime_replay(dir.path(), &input, &out);
    // the replay is waiting for the second frame
    let (status, left, err) = sigterm_after(
        &mut child,
        Duration::from_millis(1500),
        true,
        Duration::from_secs(5),
    );
    assert!(status.success(), "{status}: {err}");
    assert!(
        left < Duration::from_secs(3) && t0.elapsed() < Duration::from_secs(8),
        "left {left:?} after SIGTERM, {:?} after start",
        t0.elapsed()
    );
    assert!(assert_finished_mcap(&out) > 0);
}

#[test]
fn sigterm_with_a_sink_stuck_in_a_write_leaves_within_the_timeout_and_finishes_the_recording() {
    let dir = tempfile::tempdir().unwrap();
    // The results file is a FIFO that is open for reading but never read: once the pipe is full,
    // that sink blocks in write(2) for good, and the pipeline behind it fills up and stops.
    let fifo = dir.path().join("results.fifo");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let _reader = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(&fifo)
        .unwrap();
    let rec = dir.path().join("rec.mcap");
    let cfg = dir.path().join("stuck.toml");
    let timeout_ms = 2000;
    std::fs::write(
        &cfg,
        format!(
            "[daemon]\nthreads = 1\nshutdown_timeout_ms = {timeout_ms}\n[compute]\ndetect = false\n\
             [publish]\nenabled = false\n[record]\nenabled = true\npath = {rec:?}\n\
             [[camera]]\nname = \"stuck\"\nsource = \"synthetic\"\nwidth = 64\nheight = 48\nframes = 1000000\n"
        ),
    )
    .unwrap();
    let mut child = Command::new(BIN)
        .args(["run", "--config"])
        .arg(&cfg)
        .arg("--results")
        .arg(&fifo)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Long enough for the pipe (64 KiB) and the sink's queue to fill; the daemon is stuck.
    let (status, left, err) =
        sigterm_after(&mut child, Duration::from_secs(3), true, Duration::from_secs(10));
    assert!(
        left < Duration::from_millis(timeout_ms + 1500),
        "left {left:?} after SIGTERM with a {timeout_ms} ms timeout"
    );
    assert!(!status.success(), "a drain cut short is a failure: {err}");
    assert!(
        err.contains("shutdown did not finish within daemon.shutdown_timeout_ms"),
        "{err}"
    );
    // The recorder was not the stuck sink: it skipped what it still had queued and finished.
    assert!(assert_finished_mcap(&rec) > 0);
}
