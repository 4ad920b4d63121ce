//! `mosaicd replay` on the committed synthetic recording (recordings/synthetic_pan.mcap, made
//! entirely by our own code) with MCAP output: the output opens, holds every frame's annotations
//! and detections, and equals the golden (recordings/golden/daemon-synthetic_pan.txt) byte for byte
//! after removing wall-clock fields, for 1, 2 and 4 threads, twice. `REGENERATE=1` rewrites it.
//! Also: SIGTERM mid-replay gives a complete, indexed MCAP; SIGKILL mid-recording leaves a file
//! whose complete chunks read back and the next start succeeds without overwriting it; truncated and corrupt inputs give
//! clear errors with what was already processed kept.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use mosaicd::record::Topics;
use mosaicd::wire::{for_each_message, RecordingInfo};

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");
const FRAMES: u64 = 12;

fn recording() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/synthetic_pan.mcap")
}

fn replay(input: &Path, out: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.arg("replay")
        .arg(input)
        .arg("--out")
        .arg(out)
        .arg("--no-publish")
        .args(args);
    c.env("RUST_LOG", "warn");
    c
}

/// `mosaicd run --config CFG`, which must succeed.
fn run_config(cfg: &Path) {
    let o = Command::new(BIN)
        .args(["run", "--config"])
        .arg(cfg)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr_of(&o));
}

fn stderr_of(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// FNV-1a, to fingerprint binary payloads in the canonical dump.
fn fnv(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

/// One line per message: topic, log time, and the payload with wall-clock fields removed (JSON:
/// the `"wall"` group; periodic stats, whose count depends on timing, are left out). An image's
/// base64 `data` (the preview) is fingerprinted.
fn canonical(path: &Path) -> String {
    let mut out = String::new();
    for_each_message(path, |m| {
        let body = match serde_json::from_slice::<serde_json::Value>(&m.data) {
            Ok(mut v) => {
                if v["type"] == "stats" {
                    return Ok(());
                }
                if let Some(o) = v.as_object_mut() {
                    o.remove("wall");
                    if let Some(serde_json::Value::String(d)) = o.get_mut("data") {
                        *d = format!("base64 {} chars fnv {:016x}", d.len(), fnv(d.as_bytes()));
                    }
                }
                v.to_string()
            }
            Err(_) => format!("binary {} bytes fnv {:016x}", m.data.len(), fnv(&m.data)),
        };
        out.push_str(&format!("{} {} {}\n", m.channel.topic, m.log_time, body));
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    out
}

#[test]
fn replay_to_mcap_is_byte_identical_for_1_2_4_threads_twice_and_matches_the_golden() {
    let dir = tempfile::tempdir().unwrap();
    let mut dumps = Vec::new();
    let mut files = Vec::new();
    for round in 0..2 {
        for threads in ["1", "2", "4"] {
            let out = dir.path().join(format!("o{round}-{threads}.mcap"));
            let results = dir.path().join(format!("o{round}-{threads}.jsonl"));
            let o = replay(
                &recording(),
                &out,
                &[
                    "--threads",
                    threads,
                    "--max-in-flight",
                    threads,
                    "--camera",
                    "pan",
                    "--results",
                    results.to_str().unwrap(),
                ],
            )
            .output()
            .unwrap();
            assert!(o.status.success(), "{}", stderr_of(&o));
            let info = RecordingInfo::read(&out).unwrap();
            let topics = Topics::new("pan");
            assert_eq!(
                info.count(&topics.annotations),
                FRAMES,
                "every frame's annotations"
            );
            assert_eq!(info.count(&topics.detections), FRAMES, "every frame's detections");
            // `--out` records a preview by default, for Foxglove's image panel.
            assert_eq!(info.count(&topics.preview), FRAMES, "every frame's preview");
            dumps.push((format!("round {round}, {threads} threads"), canonical(&out)));
            files.push((std::fs::read(&out).unwrap(), std::fs::read(&results).unwrap()));
        }
    }
    for (name, d) in &dumps[1..] {
        assert_eq!(d, &dumps[0].1, "{name} differs from round 0 with 1 thread");
    }
    // A replay leaves wall-clock values out of its files (daemon.deterministic_outputs), so the
    // files themselves, not only their canonical dumps, are the same bytes every time.
    for (k, (mcap, jsonl)) in files.iter().enumerate().skip(1) {
        assert!(mcap == &files[0].0, "{}: MCAP bytes differ", dumps[k].0);
        assert!(jsonl == &files[0].1, "{}: results bytes differ", dumps[k].0);
    }
    let text = String::from_utf8_lossy(&files[0].1);
    assert_eq!(
        text.lines().count() as u64,
        FRAMES + 1,
        "frames and the final stats only"
    );
    assert!(!text.contains("\"wall\""), "{text}");
    assert!(text.lines().last().unwrap().contains("\"final_stats\""));
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/golden/daemon-synthetic_pan.txt");
    if std::env::var_os("REGENERATE").is_some() {
        std::fs::write(&golden, &dumps[0].1).unwrap();
    }
    let want = std::fs::read_to_string(&golden)
        .unwrap_or_else(|e| panic!("{}: {e} (run with REGENERATE=1 to create it)", golden.display()));
    assert_eq!(dumps[0].1, want, "output differs from {}", golden.display());
}

#[test]
fn replay_with_wall_clock_keeps_latency_and_throughput_in_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let (out, results) = (dir.path().join("w.mcap"), dir.path().join("w.jsonl"));
    let o = replay(
        &recording(),
        &out,
        &["--wall-clock", "--results", results.to_str().unwrap()],
    )
    .output()
    .unwrap();
    assert!(o.status.success(), "{}", stderr_of(&o));
    let text = std::fs::read_to_string(&results).unwrap();
    let last: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    assert_eq!(last["type"], "final_stats");
    assert!(last["wall"]["fps"].as_f64().unwrap() > 0.0, "{last}");
    let first: serde_json::Value = text
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .find(|v| v["type"] == "frame")
        .unwrap();
    assert!(first["wall"]["latency_ns"].is_u64(), "{first}");
    let mut wall_stats = 0;
    for_each_message(&out, |m| {
        if m.channel.topic.ends_with("/stats") {
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            wall_stats += v.get("wall").is_some() as usize;
        }
        Ok(())
    })
    .unwrap();
    assert!(wall_stats >= 1, "the recorded final stats keep the wall group");
}

#[test]
fn the_daemon_rotates_its_recording_and_keeps_at_most_max_files() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("ring.toml");
    let base = dir.path().join("ring.mcap");
    // 90 synthetic frames at 30 fps: 3 s of recorded time, a new file every second, two kept.
    std::fs::write(
        &cfg,
        format!(
            "[publish]\nenabled = false\n[compute]\ndetect = false\n\
             [record]\nenabled = true\npath = {:?}\nrotate_secs = 1\nmax_files = 2\n\
             [[camera]]\nname = \"ring\"\nsource = \"synthetic\"\nwidth = 64\nheight = 48\nfps = 30.0\nframes = 90\n",
            base.to_str().unwrap()
        ),
    )
    .unwrap();
    run_config(&cfg);
    let mut left: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".mcap"))
        .collect();
    left.sort();
    assert_eq!(left, ["ring-0002.mcap", "ring-0003.mcap"]);
    let topics = Topics::new("ring");
    let n: u64 = left
        .iter()
        .map(|f| {
            RecordingInfo::read(dir.path().join(f))
                .unwrap()
                .count(&topics.detections)
        })
        .sum();
    assert_eq!(n, 60, "the last two seconds' results");
}

#[test]
fn sigterm_mid_replay_gives_a_complete_indexed_mcap() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("looped.mcap");
    // --loop --realtime: endless at 30 fps until the signal.
    let mut child = replay(&recording(), &out, &["--loop", "--realtime", "--camera", "loop"])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "did not stop within 20 s"
        );
        std::thread::sleep(Duration::from_millis(10));
    };
    assert!(status.success(), "{status:?}");
    // Summary and index present: the summary-based reader opens it.
    let info = RecordingInfo::read(&out).unwrap();
    let n = info.count(&Topics::new("loop").detections);
    assert!(n > 0);
    assert_eq!(info.count(&Topics::new("loop").annotations), n);
    let mut summary = std::fs::File::open(&out).unwrap();
    assert!(
        mosaicd::wire::read_summary(&mut summary).unwrap().is_some(),
        "summary written"
    );
}

#[test]
fn sigkill_mid_recording_keeps_complete_chunks_and_the_next_start_succeeds() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("killed.mcap");
    let mut child = replay(&recording(), &out, &["--loop", "--realtime", "--camera", "kill"])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(2500));
    child.kill().unwrap();
    child.wait().unwrap();
    // Stream the file: every message of a complete chunk reads back, then an error at the cut.
    let mut n = 0;
    let _ = for_each_message(&out, |m| {
        if m.channel.topic == "/kill/detections" {
            n += 1;
        }
        Ok(())
    });
    assert!(n >= 4, "flushed chunks read back: {n} detections");
    // The restart (as systemd would do it: same config, same path) succeeds and keeps the killed
    // run's file as it was: the new recording is numbered next to it.
    let killed = std::fs::read(&out).unwrap();
    let cfg = dir.path().join("service.toml");
    std::fs::write(
        &cfg,
        format!(
            "[publish]\nenabled = false\n[record]\nenabled = true\npath = {:?}\n\
             [[camera]]\nname = \"kill\"\nsource = \"mcap\"\npath = {:?}\n",
            out.to_str().unwrap(),
            recording().to_str().unwrap()
        ),
    )
    .unwrap();
    run_config(&cfg);
    assert!(
        std::fs::read(&out).unwrap() == killed,
        "the killed run's recording was overwritten"
    );
    let again = dir.path().join("killed-0001.mcap");
    let info = RecordingInfo::read(&again).unwrap();
    assert_eq!(info.count(&Topics::new("kill").detections), FRAMES);
    // `replay --out FILE` is a command-line output: it overwrites FILE.
    let o = replay(&recording(), &again, &["--camera", "kill"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr_of(&o));
    assert!(!dir.path().join("killed-0002.mcap").exists());
    assert_eq!(
        RecordingInfo::read(&again)
            .unwrap()
            .count(&Topics::new("kill").detections),
        FRAMES
    );
}

#[test]
fn truncated_and_corrupt_inputs_are_clear_errors_and_keep_what_was_processed() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(recording()).unwrap();
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let out = dir.path().join("cut-out.mcap");
    let o = replay(&cut, &out, &["--camera", "cut"]).output().unwrap();
    assert!(!o.status.success());
    let err = stderr_of(&o);
    assert!(err.contains("input ended with an error"), "{err}");
    let summary = String::from_utf8_lossy(&o.stdout);
    assert!(summary.contains("failed: source 1"), "{summary}");
    // What was read before the cut was processed and recorded, and the output is complete.
    let info = RecordingInfo::read(&out).unwrap();
    let n = info.count(&Topics::new("cut").detections);
    assert!(n > 0 && n < FRAMES, "{n}");

    let mut bad = bytes.clone();
    for b in &mut bad[100..400] {
        *b ^= 0x5a;
    }
    let corrupt = dir.path().join("corrupt.mcap");
    std::fs::write(&corrupt, &bad).unwrap();
    let o = replay(&corrupt, &dir.path().join("c-out.mcap"), &["--camera", "bad"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = stderr_of(&o);
    assert!(err.contains("corrupt.mcap"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// Detections sequence numbers in `path`, in file order, and whether the whole file read back.
fn detection_sequences(path: &Path, camera: &str) -> (Vec<u64>, bool) {
    let topic = format!("/{camera}/detections");
    let mut seqs = Vec::new();
    let complete = for_each_message(path, |m| {
        if m.channel.topic == topic {
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            seqs.push(v["sequence"].as_u64().unwrap());
        }
        Ok(())
    })
    .is_ok();
    (seqs, complete)
}

/// `mosaicd run` of a live synthetic camera `name` recorded (results, `record_extra` keys) into
/// `dir/name.mcap`, no publishing, no detection; its stderr (`--log info`) collected as it comes,
/// and the process killed if the test ends without stopping it.
struct Service {
    child: Option<std::process::Child>,
    log: std::sync::Arc<std::sync::Mutex<String>>,
    reader: Option<std::thread::JoinHandle<()>>,
    base: PathBuf,
}

impl Service {
    fn start(dir: &Path, name: &str, record_extra: &str, camera_extra: &str) -> Self {
        use std::io::{BufRead, BufReader};
        let base = dir.join(format!("{name}.mcap"));
        let cfg = dir.join(format!("{name}.toml"));
        std::fs::write(
            &cfg,
            format!(
                "[daemon]\nthreads = 2\nstats_interval_ms = 200\n[publish]\nenabled = false\n\
                 [record]\nenabled = true\npath = {:?}\n{record_extra}\n[compute]\ndetect = false\n\
                 [[camera]]\nname = \"{name}\"\nsource = \"synthetic\"\nframes = 0\nlive = true\n{camera_extra}\n",
                base.to_str().unwrap()
            ),
        )
        .unwrap();
        let mut child = Command::new(BIN)
            .args(["run", "--log", "info", "--config"])
            .arg(&cfg)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let log = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
        let reader = {
            let (log, stderr) = (log.clone(), child.stderr.take().unwrap());
            std::thread::spawn(move || {
                for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                    let mut l = log.lock().unwrap();
                    l.push_str(&line);
                    l.push('\n');
                }
            })
        };
        Self {
            child: Some(child),
            log,
            reader: Some(reader),
            base,
        }
    }

    fn pid(&self) -> libc::pid_t {
        self.child.as_ref().unwrap().id() as libc::pid_t
    }

    fn log(&self) -> String {
        self.log.lock().unwrap().clone()
    }

    fn has(&self, s: &str) -> bool {
        self.log.lock().unwrap().contains(s)
    }

    /// Poll `what` every 20 ms for up to 30 s; on time-out fail naming `name`, with the log.
    fn wait_for(&self, what: impl Fn() -> bool, name: &str) {
        let start = Instant::now();
        while !what() {
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "timed out waiting for {name}; log:\n{}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// SIGTERM, then the exit status, stdout and the whole log.
    fn stop(mut self) -> (std::process::ExitStatus, String, String) {
        // SAFETY: plain kill(2) on our own child's pid.
        unsafe { libc::kill(self.pid(), libc::SIGTERM) };
        let out = self.child.take().unwrap().wait_with_output().unwrap();
        self.reader.take().unwrap().join().unwrap();
        (
            out.status,
            String::from_utf8_lossy(&out.stdout).into_owned(),
            self.log(),
        )
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        if let Some(c) = &mut self.child {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// The `.mcap` files in `dir`, sorted (`name-NNNN.mcap` sorts before `name.mcap`).
fn mcap_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    v.sort();
    v
}

/// A full disk in the middle of a service's recording, made with a file-size limit on the
/// running daemon (`prlimit`, as systemd's `LimitFSIZE=` would set it): the recording pauses
/// (counted once, logged), attempts while the limit holds fail and leave no empty files, and
/// once writes succeed again the recording resumes in a new numbered file; the file that failed
/// keeps what it had. Detection never stopped, and a SIGTERM stop exits 0.
#[test]
fn a_full_disk_pauses_the_recording_and_it_resumes_in_a_new_file() {
    let dir = tempfile::tempdir().unwrap();
    let svc = Service::start(
        dir.path(),
        "full",
        "frames = true\nretry_ms = 200",
        "width = 320\nheight = 240\nfps = 30.0",
    );
    let (pid, base) = (svc.pid(), svc.base.clone());
    svc.wait_for(
        || base.exists() && detection_sequences(&base, "full").0.len() >= 3,
        "the first frames on disk",
    );

    // The disk is "full": every write past byte 1 of any file fails (EFBIG, SIGXFSZ ignored).
    let mut old = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: prlimit(2) on our own child, reading into and from valid rlimit structs.
    assert_eq!(
        unsafe { libc::prlimit(pid, libc::RLIMIT_FSIZE, std::ptr::null(), &mut old) },
        0
    );
    let full = libc::rlimit {
        rlim_cur: 1,
        rlim_max: old.rlim_max,
    };
    assert_eq!(
        unsafe { libc::prlimit(pid, libc::RLIMIT_FSIZE, &full, std::ptr::null_mut()) },
        0
    );
    svc.wait_for(|| svc.has("recording paused"), "the pause");
    svc.wait_for(
        || svc.log().matches("still failing").count() >= 2,
        "two failed attempts",
    );
    // Space again.
    assert_eq!(
        unsafe { libc::prlimit(pid, libc::RLIMIT_FSIZE, &old, std::ptr::null_mut()) },
        0
    );
    svc.wait_for(|| svc.has("recording resumed in a new file"), "the resume");
    svc.wait_for(
        || {
            let files = mcap_files(dir.path());
            files.len() >= 2 && detection_sequences(&files[files.len() - 2], "full").0.len() >= 5
        },
        "five frames in the new file",
    );
    let (status, stdout, log) = svc.stop();
    assert!(status.success(), "{status:?}\n{stdout}\n{log}");
    assert!(stdout.contains("sink 1"), "the outage counted once:\n{stdout}");
    assert!(stdout.contains("sink interrupted"), "{stdout}");
    assert!(!stdout.contains("sink error"), "{stdout}");
    assert!(
        stdout.contains("File too large"),
        "the OS error is named:\n{stdout}"
    );

    // The file that failed and the one the recording resumed in; the failed attempts' files
    // (nothing in them) are gone.
    let files = mcap_files(dir.path());
    let sizes: Vec<u64> = files
        .iter()
        .map(|f| std::fs::metadata(f).unwrap().len())
        .collect();
    assert_eq!(files.len(), 2, "{files:?} {sizes:?}\n{log}");
    // `full-NNNN.mcap` sorts before `full.mcap`.
    assert_eq!(files[1], base);
    let (before, _) = detection_sequences(&files[1], "full");
    let (after, complete) = detection_sequences(&files[0], "full");
    assert!(!before.is_empty(), "the failed file keeps its flushed frames");
    assert!(complete, "the resumed file is complete (finished on SIGTERM)");
    assert!(after.len() >= 5, "{} frames after the resume", after.len());
    assert!(before.windows(2).all(|w| w[0] < w[1]));
    assert!(after.windows(2).all(|w| w[0] < w[1]));
    assert!(
        after[0] > *before.last().unwrap() + 1,
        "frames during the outage are not recorded: {} then {}",
        before.last().unwrap(),
        after[0]
    );
    // ... and counted: every processed frame between the two files (all of them unless the live
    // queue dropped some, which the summary also counts)
    let count = |key: &str| -> u64 {
        let at = stdout
            .find(key)
            .unwrap_or_else(|| panic!("no {key:?} in\n{stdout}"))
            + key.len();
        let digits: String = stdout[at..].chars().take_while(char::is_ascii_digit).collect();
        digits.parse().unwrap()
    };
    let (lost, dropped) = (count("frames sinks lost "), count("queue_full "));
    let gap = after[0] - before.last().unwrap() - 1;
    assert!(
        lost >= 1 && lost <= gap && lost + dropped >= gap,
        "lost {lost}, gap {gap}\n{stdout}"
    );
    if dropped == 0 {
        assert_eq!(lost, gap, "{stdout}");
    }
    // subscribers see it too: the resumed file's last stats record (the final one) carries it
    let mut last_stats = None;
    for_each_message(&files[0], |m| {
        if m.channel.topic == "/full/stats" {
            last_stats = Some(serde_json::from_slice::<serde_json::Value>(&m.data).unwrap());
        }
        Ok(())
    })
    .unwrap();
    let last_stats = last_stats.expect("stats records in the resumed file");
    assert_eq!(last_stats["type"], "final_stats", "{last_stats}");
    assert_eq!(
        last_stats["sink_frames_lost"].as_u64(),
        Some(lost),
        "{last_stats}"
    );
}

/// SIGHUP (`systemctl reload`): the recording file is finished (complete, indexed) and the next
/// frame starts a new numbered one; no frame is lost between them, and the daemon goes on.
#[test]
fn sighup_finishes_the_recording_file_and_starts_the_next_without_losing_a_frame() {
    let dir = tempfile::tempdir().unwrap();
    let svc = Service::start(
        dir.path(),
        "hup",
        "flush_frames = 1",
        "width = 96\nheight = 64\nfps = 60.0",
    );
    let base = svc.base.clone();
    let files = || mcap_files(dir.path());
    let frames_in_newest = |n: usize| {
        let f = files();
        // `hup-NNNN.mcap` sorts before `hup.mcap`: the newest is the last numbered one.
        let newest = f.iter().rev().find(|p| **p != base).unwrap_or(&base).clone();
        detection_sequences(&newest, "hup").0.len() >= n
    };
    svc.wait_for(
        || base.exists() && frames_in_newest(5),
        "frames in the first file",
    );
    for k in 1..=2 {
        // SAFETY: plain kill(2) on our own child's pid.
        unsafe { libc::kill(svc.pid(), libc::SIGHUP) };
        svc.wait_for(|| files().len() == k + 1, "a new file");
        svc.wait_for(|| frames_in_newest(5), "frames in the new file");
    }
    let (status, stdout, log) = svc.stop();
    assert!(status.success(), "{status:?}\n{stdout}\n{log}");
    assert!(stdout.contains("frames sinks lost 0"), "nothing lost:\n{stdout}");
    assert!(stdout.contains("sink 0"), "{stdout}");
    // Three complete files (each finished with its index), frames contiguous across them.
    let f = files();
    assert_eq!(f.len(), 3, "{f:?}");
    let order = [&base, &f[0], &f[1]];
    let mut all = Vec::new();
    for p in order {
        let (seqs, complete) = detection_sequences(p, "hup");
        assert!(complete, "{} is complete", p.display());
        assert!(RecordingInfo::read(p).is_ok(), "{} has its summary", p.display());
        assert!(!seqs.is_empty());
        all.extend(seqs);
    }
    // Every processed frame is in exactly one file (a live source may drop frames before
    // processing: those are neither processed nor recorded).
    assert!(all.windows(2).all(|w| w[0] < w[1]), "in order, none repeated");
    let processed: usize = stdout
        .split("camera hup: ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no frame count in {stdout}"));
    assert_eq!(all.len(), processed, "no processed frame lost between the files");
}

#[test]
fn logs_to_a_pipe_have_no_colour_codes_and_print_values_not_options() {
    // stderr is a pipe here, as under journald or in CI: plain text (colour only on a terminal).
    let dir = tempfile::tempdir().unwrap();
    let o = replay(&recording(), &dir.path().join("l.mcap"), &[])
        .env("RUST_LOG", "info")
        .env_remove("NO_COLOR")
        .output()
        .unwrap();
    let err = stderr_of(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("INFO"), "{err}");
    assert!(!err.contains('\x1b'), "ANSI escapes in a piped log: {err:?}");
    assert!(!err.contains("Some("), "{err}");
}

/// The metadata records of an MCAP file: (name, key → value).
fn metadata_of(path: &Path) -> Vec<(String, std::collections::BTreeMap<String, String>)> {
    let buf = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&buf).unwrap().expect("a summary");
    summary
        .metadata_indexes
        .iter()
        .map(|i| {
            let m = mcap::read::metadata(&buf, i).unwrap();
            (m.name, m.metadata)
        })
        .collect()
}

#[test]
fn a_live_recording_carries_the_wall_clock_and_a_replay_does_not() {
    use mosaicd::record::WALL_CLOCK_METADATA;
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("live.toml");
    let path = dir.path().join("live.mcap");
    std::fs::write(
        &cfg,
        format!(
            "[publish]\nenabled = false\n[compute]\ndetect = false\n\
             [record]\nenabled = true\npath = {:?}\n\
             [[camera]]\nname = \"live\"\nsource = \"synthetic\"\nwidth = 64\nheight = 48\nfps = 100.0\nframes = 10\nlive = true\n",
            path.to_str().unwrap()
        ),
    )
    .unwrap();
    run_config(&cfg);
    let now = mosaicd::clock::WallClock::now();
    let meta = metadata_of(&path);
    assert_eq!(meta.len(), 1, "{meta:?}");
    let (name, m) = &meta[0];
    assert_eq!(name, WALL_CLOCK_METADATA);
    assert_eq!(m["timestamps"], "CLOCK_MONOTONIC");
    let offset: i128 = m["realtime_minus_monotonic_ns"].parse().unwrap();
    assert!((offset - now.offset_ns()).abs() < 1_000_000_000, "{m:?}");
    assert!(m["realtime_utc"].ends_with('Z'), "{m:?}");
    // The frames' log times are this boot's monotonic time; with the offset, this run's wall time.
    let info = RecordingInfo::read(&path).unwrap();
    let start_wall = info.start_ns as i128 + offset;
    assert!(
        (start_wall - now.realtime_ns as i128).abs() < 60_000_000_000,
        "{m:?}"
    );

    // A replay's times are the recording's: no reading of today's clocks in its file.
    let out = dir.path().join("replay.mcap");
    let o = replay(&recording(), &out, &[]).output().unwrap();
    assert!(o.status.success(), "{}", stderr_of(&o));
    assert!(metadata_of(&out).is_empty());
}
