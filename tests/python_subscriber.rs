//! The Python subscriber (`clients/python/mosaicd_subscriber.py`, ctypes structures over the
//! `iceoryx2` wheel) against the real daemon: its structures have the Rust messages' sizes,
//! alignments and iceoryx2 type names, and a Python process subscribed to a running daemon reads
//! every frame's boxes, keypoints and descriptors exactly as the daemon wrote them to its results
//! file. Needs python3 with the packages of `clients/python/requirements.txt` and, for the
//! matching, OpenCV from `tests/oracle/requirements.txt` (`make setup`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use iceoryx2::prelude::ZeroCopySend;
use mosaicd::publish::messages::{
    BoxMsg, DescriptorsMsg, DetectionsMsg, GradientsHeader, KeypointMsg, KeypointsMsg, StatsMsg,
};

mod common;

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("clients/python/mosaicd_subscriber.py")
}

fn python() -> Command {
    let mut c = Command::new("python3");
    c.arg(script());
    c
}

/// The Python client resolves `--root auto` by the daemon's rule ([`resolve_root`]) and names its
/// segments as the daemon does ([`segment_prefix`]), for every case of the rule.
#[test]
fn python_resolves_the_root_and_segment_prefix_as_the_daemon() {
    use mosaicd::config::Iox2Root;
    use mosaicd::publish::{resolve_root, segment_prefix, RootEnv};
    let t = tempfile::tempdir().unwrap();
    let base = t.path();
    std::fs::create_dir(base.join("xdg")).unwrap();
    // SAFETY: geteuid has no preconditions.
    let me = unsafe { libc::geteuid() };
    let xdg = base.join("xdg").to_str().unwrap().to_string();
    let cases: Vec<(u32, Option<&str>, Option<&str>)> = vec![
        (0, None, None),
        (me, None, Some(&xdg)),
        (me + 1, None, Some(&xdg)),
        (4242, None, None),
        (4242, Some("/run/mosaicd:/run/x"), Some(&xdg)),
        (4242, Some("rel"), Some("rel")),
    ];
    for (uid, rd, xd) in cases {
        let env = RootEnv {
            uid,
            runtime_directory: rd.map(Into::into),
            xdg_runtime_dir: xd.map(Into::into),
            system_dir: base.join("run-mosaicd"),
            tmp_dir: base.join("tmp"),
        };
        let (want, _) = resolve_root(&Iox2Root::Auto, &env);
        let code = format!(
            "import sys; sys.path.insert(0, {dir:?}); import mosaicd_subscriber as m\n\
             env = {{k: v for k, v in (('RUNTIME_DIRECTORY', {rd:?}), ('XDG_RUNTIME_DIR', {xd:?})) if v != 'None'}}\n\
             r = m.resolve_root('auto', uid={uid}, env=env, system_dir={sys:?}, tmp_dir={tmp:?})\n\
             print(r); print(m.segment_prefix(r))",
            dir = script().parent().unwrap().to_str().unwrap(),
            rd = rd.unwrap_or("None"),
            xd = xd.unwrap_or("None"),
            sys = base.join("run-mosaicd").to_str().unwrap(),
            tmp = base.join("tmp").to_str().unwrap(),
        );
        let out = Command::new("python3")
            .args(["-c", &code])
            .output()
            .expect("python3 runs");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout);
        let got: Vec<&str> = text.lines().collect();
        assert_eq!(
            got,
            [want.to_str().unwrap(), segment_prefix(&want).as_str()],
            "uid {uid}, RUNTIME_DIRECTORY {rd:?}, XDG_RUNTIME_DIR {xd:?}"
        );
    }
}

/// Size, alignment, iceoryx2 type name and field offsets of a message type.
fn rust_layout<T: ZeroCopySend>(
    fields: Vec<(&'static str, usize)>,
) -> (String, usize, usize, Vec<(&'static str, usize)>) {
    // SAFETY: `type_name` only returns the name given in `#[type_name]`.
    let name = unsafe { <T as ZeroCopySend>::type_name() }.to_string();
    (name, std::mem::size_of::<T>(), std::mem::align_of::<T>(), fields)
}

/// `(field, offset)` of each named field of a type.
macro_rules! offsets {
    ($t:ty; $($f:ident),+ $(,)?) => {
        vec![$((stringify!($f), std::mem::offset_of!($t, $f))),+]
    };
}

#[test]
fn python_structures_match_the_rust_messages() {
    let out = python().arg("--layout").output().expect("python3 runs");
    assert!(
        out.status.success(),
        "the Python subscriber failed (is the iceoryx2 wheel installed? run `make setup`): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let py: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rust = [
        rust_layout::<BoxMsg>(offsets!(BoxMsg; x, y, width, height, score)),
        rust_layout::<DetectionsMsg>(offsets!(DetectionsMsg; index, sequence, sensor_sequence,
            capture_timestamp_ns, publish_timestamp_ns, latency_ns, frame_width, frame_height,
            box_count, overflow, mean_magnitude, reserved, boxes)),
        rust_layout::<KeypointMsg>(offsets!(KeypointMsg; x, y, size, angle, response)),
        rust_layout::<KeypointsMsg>(offsets!(KeypointsMsg; index, sequence, capture_timestamp_ns,
            publish_timestamp_ns, frame_width, frame_height, keypoint_count, overflow, keypoints)),
        rust_layout::<DescriptorsMsg>(offsets!(DescriptorsMsg; index, sequence, capture_timestamp_ns,
            descriptor_count, overflow, descriptors)),
        rust_layout::<StatsMsg>(offsets!(StatsMsg; timestamp_ns, captured, processed,
            dropped_queue_full, dropped_driver, failed_source, failed_compute, failed_sink,
            sink_frames_lost, detections, box_overflow, fps, latency_p50_us, latency_p99_us, is_final)),
        rust_layout::<GradientsHeader>(offsets!(GradientsHeader; index, capture_timestamp_ns, width,
            height, decimation, orientation_bins, mag_shift, reserved)),
    ];
    assert_eq!(py.as_object().unwrap().len(), rust.len(), "{py}");
    for (name, size, align, fields) in rust {
        let p = &py[&name];
        assert!(p.is_object(), "no Python structure named {name}: {py}");
        assert_eq!(
            (p["size"].as_u64(), p["align"].as_u64()),
            (Some(size as u64), Some(align as u64)),
            "{name}"
        );
        // Every field at the same offset, and no field more or less (a swap of two fields of one
        // size keeps the size but not the offsets).
        let pf = p["fields"].as_object().unwrap();
        assert_eq!(pf.len(), fields.len(), "{name}: {pf:?}");
        for (f, off) in fields {
            assert_eq!(pf.get(f).and_then(|v| v.as_u64()), Some(off as u64), "{name}.{f}");
        }
    }
}

/// `got` (a Python JSON number, an f32 widened to f64) equals `want` (the results file's number,
/// written by Rust from the same f32), compared as f32.
fn same_f32(got: &serde_json::Value, want: &serde_json::Value) -> bool {
    got.as_f64().map(|g| g as f32) == want.as_f64().map(|w| w as f32)
}

fn json_lines(text: &str) -> Vec<serde_json::Value> {
    text.lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

/// A Python process subscribed to a running daemon (six INRIA person crops played as raw files,
/// detection with OpenCV's weights, keypoints with descriptors) receives every frame's message
/// with the same content as the results file, then the final stats.
#[test]
fn a_python_process_reads_what_the_daemon_publishes() {
    let crops = mosaicd::data::require("pedestrian/inria_pos_96x160");
    let dir = tempfile::tempdir().unwrap();
    let frames_dir = dir.path().join("frames");
    std::fs::create_dir(&frames_dir).unwrap();
    let mut names: Vec<PathBuf> = std::fs::read_dir(&crops)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    names.sort();
    for (i, p) in names.iter().take(6).enumerate() {
        std::os::unix::fs::symlink(p, frames_dir.join(format!("{i:02}.png"))).unwrap();
    }
    let (prefix, camera) = (format!("py{}", std::process::id()), "pycam");
    let cfg = dir.path().join("py.toml");
    std::fs::write(
        &cfg,
        format!(
            "[daemon]\nthreads = 2\nstats_interval_ms = 100\n\
             [publish]\nservice_prefix = \"{prefix}\"\nsubscriber_buffer = 64\n\
             [compute]\nkeypoints = true\nkeypoint_descriptors = true\n\
             [[camera]]\nname = \"{camera}\"\nsource = \"files\"\npath = {:?}\nfps = 10.0\n",
            frames_dir.display().to_string()
        ),
    )
    .unwrap();

    let results = dir.path().join("results.jsonl");
    let msgs = with_python_subscriber(
        "mosaicd_subscriber.py",
        &[
            "--camera",
            camera,
            "--prefix",
            &prefix,
            "--keypoints",
            "--descriptors",
        ],
        &cfg,
        Some(&results),
    );

    let frames: Vec<serde_json::Value> = json_lines(&std::fs::read_to_string(&results).unwrap())
        .into_iter()
        .filter(|r| r["type"] == "frame")
        .collect();
    assert_eq!(frames.len(), 6);
    let of =
        |topic: &str| -> Vec<&serde_json::Value> { msgs.iter().filter(|m| m["topic"] == topic).collect() };
    let (dets, kps, descs) = (of("detections"), of("keypoints"), of("descriptors"));
    assert_eq!(
        (dets.len(), kps.len(), descs.len()),
        (6, 6, 6),
        "one of each per frame"
    );

    let mut boxes = 0;
    for (((d, k), ds), f) in dets.iter().zip(&kps).zip(&descs).zip(&frames) {
        for key in [
            "index",
            "sequence",
            "capture_timestamp_ns",
            "publish_timestamp_ns",
        ] {
            assert_eq!(d[key], f[key], "{key}");
            assert_eq!(k[key], f[key], "{key}");
        }
        assert_eq!(
            (&d["frame_width"], &d["frame_height"]),
            (&f["width"], &f["height"])
        );
        let want = f["detections"].as_array().unwrap();
        let got = d["boxes"].as_array().unwrap();
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            for key in ["x", "y", "width", "height", "score"] {
                assert!(same_f32(&g[key], &w[key]), "box {key}: {g} vs {w}");
            }
        }
        boxes += got.len();
        assert!(same_f32(&d["mean_magnitude"], &f["mean_magnitude"]));

        let want = f["keypoints"].as_array().unwrap();
        let got = k["keypoints"].as_array().unwrap();
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            for key in ["x", "y", "size", "angle", "response"] {
                assert!(same_f32(&g[key], &w[key]), "keypoint {key}: {g} vs {w}");
            }
        }
        assert_eq!(ds["index"], f["index"]);
        assert_eq!(ds["descriptor_count"].as_u64(), Some(want.len() as u64));
        assert_eq!(ds["descriptors"], f["descriptors"], "descriptors (base64)");
    }
    // OpenCV's weights fire on 2 of these 6 crops (no upsampling); the comparison needs some.
    assert!(boxes >= 1, "no box to compare");

    let last = of("stats").into_iter().last().cloned().unwrap();
    assert_eq!(
        (last["is_final"].as_u64(), last["processed"].as_u64()),
        (Some(1), Some(6))
    );
}

/// A service the Python subscriber cannot use is refused in one line naming it: a smaller
/// subscriber buffer than it asks for, and a keypoints service of another message version.
#[test]
fn an_incompatible_service_is_a_clear_error() {
    use mosaicd::publish::{create_node, detections_service};
    let prefix = format!("pyx{}", std::process::id());
    let node = create_node(
        &format!("pyx-test-{}", std::process::id()),
        false,
        &mosaicd::publish::root_dir(&mosaicd::config::Iox2Root::Auto).unwrap(),
    )
    .unwrap();
    let _det = detections_service(&node, &prefix, "c", 4).unwrap();
    let err = refused(&["--camera", "c", "--prefix", &prefix, "--buffer", "64"]);
    assert!(
        err.contains(&format!("cannot subscribe to {prefix}/c/detections")) && err.contains("--buffer 64"),
        "{err}"
    );

    // A keypoints service carrying another payload type (as another daemon version's would).
    let name: iceoryx2::prelude::ServiceName = format!("{prefix}/d/keypoints").as_str().try_into().unwrap();
    let _old = node
        .service_builder(&name)
        .publish_subscribe::<u64>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(64)
        .history_size(1)
        .max_publishers(2)
        .max_subscribers(16)
        .create()
        .unwrap();
    let err = refused(&["--camera", "d", "--prefix", &prefix, "--keypoints"]);
    assert!(
        err.contains(&format!("cannot subscribe to {prefix}/d/keypoints")),
        "{err}"
    );
}

/// Run the Python subscriber with `args`, which must fail with a one-line error: that line.
fn refused(args: &[&str]) -> String {
    let out = python().args(args).args(["--timeout-s", "5"]).output().unwrap();
    assert!(!out.status.success(), "{args:?} was accepted");
    let err = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert_eq!(err.lines().count(), 1, "one line, no traceback: {err}");
    err
}

/// The descriptors are usable as they arrive: `clients/python/match_frames.py` matches each frame's
/// keypoints with the previous frame's through OpenCV's `BFMatcher` (ratio 0.8, mutual) while the
/// daemon replays the committed synthetic pan (a 160x120 window moving from (0, 0) to (95, 71) of
/// its scene over 12 frames, odd offsets included, so the CFA phase changes between frames), and
/// the median displacement of the matches follows the window: the scene moves by minus the
/// window's step.
#[test]
fn python_matches_of_the_descriptors_track_the_recorded_pan() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = format!("pym{}", std::process::id());
    let cfg = dir.path().join("m.toml");
    let rec = Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/synthetic_pan.mcap");
    std::fs::write(
        &cfg,
        format!(
            "[daemon]\nthreads = 2\nstats_interval_ms = 100\n\
             [publish]\nservice_prefix = \"{prefix}\"\n[record]\nenabled = false\n\
             [compute]\ndetect = false\nkeypoints = true\nkeypoint_descriptors = true\n\
             [[camera]]\nname = \"pan\"\nsource = \"mcap\"\npath = {:?}\n",
            rec.display().to_string()
        ),
    )
    .unwrap();
    let pairs = with_python_subscriber(
        "match_frames.py",
        &["--camera", "pan", "--prefix", &prefix],
        &cfg,
        None,
    );
    assert_eq!(pairs.len(), 11, "one line per consecutive pair of the 12 frames");
    let (step_x, step_y) = (-95.0 / 11.0, -71.0 / 11.0);
    let (mut sum_x, mut sum_y) = (0.0, 0.0);
    for (i, p) in pairs.iter().enumerate() {
        assert_eq!(
            (p["from"].as_u64(), p["to"].as_u64()),
            (Some(i as u64), Some(i as u64 + 1))
        );
        assert!(p["matches"].as_u64().unwrap() >= 2, "{p}");
        let (dx, dy) = (p["dx"].as_f64().unwrap(), p["dy"].as_f64().unwrap());
        // The window moves by whole pixels (8 or 9 across, 6 or 7 down), so each pair is within
        // a pixel of the mean step, plus the keypoints' own error.
        assert!((dx - step_x).abs() < 2.5 && (dy - step_y).abs() < 2.5, "{p}");
        sum_x += dx;
        sum_y += dy;
    }
    // Over the whole pan (measured: -91.8, -67.6).
    assert!(
        (sum_x + 95.0).abs() < 6.0 && (sum_y + 71.0).abs() < 6.0,
        "{sum_x} {sum_y}"
    );
}

/// Run `script` (in clients/python) with `args` plus `--until-final --timeout-s 60` as a
/// subscriber, start the daemon on `cfg` (results to `results` when given) once it has subscribed,
/// and return the subscriber's stdout lines; both must succeed.
fn with_python_subscriber(
    script: &str,
    args: &[&str],
    cfg: &Path,
    results: Option<&Path>,
) -> Vec<serde_json::Value> {
    let mut sub = Command::new("python3")
        .arg(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("clients/python")
                .join(script),
        )
        .args(args)
        .args(["--until-final", "--timeout-s", "60"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 runs");
    let (line, sub_err) = wait_for_subscribed(&mut sub);
    common::assert_says_what_it_subscribed_to(&line, args);
    common::run_daemon_ok(BIN, cfg, results);
    let sout = sub.wait_with_output().unwrap();
    let err = sub_err.join().unwrap();
    assert!(sout.status.success(), "{script}: {err}");
    json_lines(&String::from_utf8_lossy(&sout.stdout))
}

/// Wait until a subscriber process says on stderr that it has subscribed; the rest of its stderr
/// is collected by a thread, whose handle gives it back once the process has ended.
fn wait_for_subscribed(sub: &mut std::process::Child) -> (String, std::thread::JoinHandle<String>) {
    use std::io::{BufRead, BufReader, Read};
    let mut err = BufReader::new(sub.stderr.take().unwrap());
    let mut line = String::new();
    let mut seen = String::new();
    while err.read_line(&mut line).unwrap() > 0 && !line.contains("subscribed") {
        seen.push_str(&line);
        line.clear();
    }
    assert!(
        line.contains("subscribed"),
        "the Python subscriber did not start (run `make setup`): {seen}{line}"
    );
    let rest = std::thread::spawn(move || {
        let mut rest = String::new();
        let _ = err.read_to_string(&mut rest);
        rest
    });
    (line, rest)
}

/// The gradients service (dynamic `u8` slices with a `GradientsHeader`) read from Python: a paced
/// live synthetic camera (so the subscriber maps the publisher's data segment while it exists, as
/// `tests/daemon_processes.rs` does for `mosaicd listen`), 96x64 decimated by 4.
#[test]
fn python_reads_the_gradient_slices() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = format!("pyg{}", std::process::id());
    let cfg = dir.path().join("g.toml");
    std::fs::write(
        &cfg,
        format!(
            "[daemon]\nthreads = 2\nstats_interval_ms = 200\n\
             [publish]\nservice_prefix = \"{prefix}\"\nsubscriber_buffer = 256\ngradients = true\n\
             [compute]\ndetect = false\n[record]\nenabled = false\n\
             [[camera]]\nname = \"g\"\nsource = \"synthetic\"\nwidth = 96\nheight = 64\n\
             frames = 20\nlive = true\nfps = 100.0\n"
        ),
    )
    .unwrap();
    let msgs = with_python_subscriber(
        "mosaicd_subscriber.py",
        &[
            "--camera",
            "g",
            "--prefix",
            &prefix,
            "--buffer",
            "256",
            "--gradients",
        ],
        &cfg,
        None,
    );
    let grads: Vec<&serde_json::Value> = msgs.iter().filter(|m| m["topic"] == "gradients").collect();
    let dets = msgs.iter().filter(|m| m["topic"] == "detections").count();
    // One gradients sample per detections message, except at most the first (segment mapping).
    assert!(
        dets > 0 && grads.len() + 1 >= dets && grads.len() <= dets,
        "{} gradients, {dets} detections",
        grads.len()
    );
    for g in &grads {
        assert_eq!(
            (g["width"].as_u64(), g["height"].as_u64()),
            (Some(24), Some(16)),
            "{g}"
        );
        assert_eq!(
            (g["payload_bytes"].as_u64(), g["orientation_bins"].as_u64()),
            (Some(24 * 16 * 3), Some(9))
        );
        assert_eq!(g["decimation"], 4);
    }
}

/// A non-finite number (a stats field before any frame, a NaN score) is printed as `null`: the
/// subscriber's lines are strict JSON, which has no `NaN` or `Infinity`.
#[test]
fn python_subscriber_prints_null_for_non_finite_numbers() {
    let dir = script().parent().unwrap().to_path_buf();
    let code = "import sys, mosaicd_subscriber as m; \
                print(m.json_line({'score': float('nan'), 'fps': float('inf'), \
                'list': [1.5, float('-inf')], 'nested': {'x': float('nan')}, 'n': 3}))";
    let out = Command::new("python3")
        .current_dir(&dir)
        .args(["-c", code])
        .output()
        .expect("python3 runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let line = String::from_utf8(out.stdout).unwrap();
    let v: serde_json::Value = serde_json::from_str(line.trim()).unwrap_or_else(|e| panic!("{line}: {e}"));
    assert_eq!(
        v,
        serde_json::json!({"score": null, "fps": null, "list": [1.5, null], "nested": {"x": null}, "n": 3})
    );
}
