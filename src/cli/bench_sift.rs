//! `mosaicd bench sift`: mosaic SIFT on a 1080p 12-bit mosaic against OpenCV's conventional path
//! (demosaic → grey → 8-bit → `SIFT.detectAndCompute`) run by Python in the same command on the
//! same frame with the same thread count. Prints the kernel path and the CPU's features
//! ([`mosaicd::kernels::describe`]; `MOSAICD_KERNELS` forces a path), both median times and the
//! ratio; `--json` prints the same as one JSON document.
//!
//! The frame is the real 1920x1080 10-bit RGGB chart `raw/openisp/test.RAW` shifted left by 2 bits
//! (a 12-bit frame with the same content).

use std::io::Write;
use std::path::PathBuf;
use std::process::Command;

use anyhow::{bail, Context};
use mosaicd::progress::Progress;

use mosaicd::features::sift::{features_from_frame, SiftSpec};
use mosaicd::kernels;

use super::bench_gradients::kernels_json;

/// The Python peer: OpenCV demosaic, grey, 8-bit, SIFT; prints "median_seconds keypoints".
const PEER: &str = r#"
import sys, time
import numpy as np, cv2
path, w, h, code, reps, threads, white = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], int(sys.argv[5]), int(sys.argv[6]), float(sys.argv[7])
cv2.setNumThreads(threads)
m = np.fromfile(path, dtype='<u2').reshape(h, w)
sift = cv2.SIFT_create()
conv = getattr(cv2, 'COLOR_' + code + '2BGR')
times, n = [], 0
for _ in range(reps):
    t0 = time.perf_counter()
    bgr = cv2.cvtColor(m, conv)
    g = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    g8 = cv2.convertScaleAbs(g, alpha=255.0 / white)
    kp, d = sift.detectAndCompute(g8, None)
    times.append(time.perf_counter() - t0)
    n = len(kp)
times.sort()
print(times[len(times) // 2], n)
"#;

/// Arguments of `mosaicd bench sift`.
#[derive(clap::Args, Debug)]
pub struct BenchSiftArgs {
    /// Repetitions (median reported).
    #[arg(long, default_value_t = 5)]
    pub reps: usize,
    /// Threads for both sides (our rayon pool, `cv2.setNumThreads`).
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Python interpreter with cv2.
    #[arg(long, default_value = "python3")]
    pub python: String,
    /// Also time mosaic SIFT with doubled colour planes.
    #[arg(long)]
    pub with_doubled: bool,
    /// Base blur sigma of the mosaic, in super-pixels (the mosaic default unless given).
    #[arg(long)]
    pub sigma: Option<f64>,
    /// Print one JSON document instead of the text lines.
    #[arg(long)]
    pub json: bool,
    /// Time mosaicd only (no OpenCV peer): for profiling.
    #[arg(long)]
    pub no_peer: bool,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Run `mosaicd bench sift`.
pub fn run(args: BenchSiftArgs) -> anyhow::Result<()> {
    anyhow::ensure!(args.reps > 0, "--reps must be at least 1");
    // the real 10-bit chart through the library's loader, promoted to a 12-bit container
    let frame = mosaicd::data::load_raw_frame(&mosaicd::data::OPENISP_TEST)?.promoted(2)?;
    let (w, h) = (frame.width(), frame.height());

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()?;
    let run_ours = |spec: SiftSpec| -> anyhow::Result<(f64, usize)> {
        let mut times = Vec::new();
        let mut n = 0;
        let bar = Progress::new("bench sift", Some(args.reps as u64));
        for r in 0..args.reps {
            bar.set(r as u64, "ours");
            let t0 = std::time::Instant::now();
            // Normalisation (black, white) and SIFT, as the daemon runs them.
            let f = pool.install(|| features_from_frame(&frame, &spec))?;
            times.push(t0.elapsed().as_secs_f64());
            n = f.keypoints.len();
        }
        Ok((median(times), n))
    };
    let mut base = SiftSpec::mosaic().with_max_value(1.0)?;
    if let Some(s) = args.sigma {
        base = base.with_sigma(s)?;
    }
    let (ours, n_ours) = run_ours(base)?;
    let doubled = if args.with_doubled {
        Some(run_ours(base.with_double_image(true))?)
    } else {
        None
    };

    if args.no_peer {
        if args.json {
            let report = serde_json::json!({
                "threads": args.threads, "reps": args.reps, "kernels": kernels_json(),
                "ours_s": ours, "ours_keypoints": n_ours,
            });
            println!("{}", serde_json::to_string_pretty(&report)?);
            return Ok(());
        }
        println!(
            "bench sift: mosaicd mosaic SIFT, {} threads, median of {} runs: {:.3} s ({n_ours} keypoints); {}",
            args.threads,
            args.reps,
            ours,
            kernels::describe()
        );
        return Ok(());
    }
    let mut tmp = tempfile_path()?;
    {
        // One buffered write (2 M unbuffered 2-byte writes took seconds of system time).
        let bytes: Vec<u8> = frame.to_u16_vec().iter().flat_map(|v| v.to_le_bytes()).collect();
        let mut f = std::fs::File::create(&tmp.0)?;
        f.write_all(&bytes)?;
    }
    let out = Command::new(&args.python)
        .arg("-c")
        .arg(PEER)
        .arg(&tmp.0)
        .arg(w.to_string())
        .arg(h.to_string())
        .arg(frame.cfa().opencv_code_name())
        .arg(args.reps.to_string())
        .arg(args.threads.to_string())
        .arg(frame.levels().white.to_string())
        .output()
        .with_context(|| format!("running {}", args.python))?;
    tmp.cleanup();
    if !out.status.success() {
        bail!("OpenCV peer failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let mut it = text.split_whitespace();
    let cv_s: f64 = it.next().context("peer output")?.parse()?;
    let cv_n: usize = it.next().context("peer output")?.parse()?;
    let commit = Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    if args.json {
        let report = serde_json::json!({
            "input": "raw/openisp/test.RAW << 2", "width": w, "height": h, "bit_depth": 12,
            "threads": args.threads, "reps": args.reps, "commit": commit, "kernels": kernels_json(),
            "opencv_s": cv_s, "opencv_keypoints": cv_n, "ours_s": ours, "ours_keypoints": n_ours,
            "speedup": cv_s / ours,
            "doubled": doubled.map(|(t, n)| serde_json::json!({"ours_s": t, "keypoints": n, "speedup": cv_s / t})),
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!("bench sift: 1920x1080 12-bit RGGB (openisp test.RAW << 2), {} threads, median of {} runs, commit {commit}", args.threads, args.reps);
    println!("  {}", kernels::describe());
    println!(
        "  OpenCV demosaic + grey + SIFT.detectAndCompute: {:.3} s ({cv_n} keypoints)",
        cv_s
    );
    println!(
        "  mosaicd mosaic SIFT (keypoints + descriptors):   {:.3} s ({n_ours} keypoints)",
        ours
    );
    println!("  speed-up: {:.2}x", cv_s / ours);
    if let Some((t, n)) = doubled {
        println!(
            "  mosaicd mosaic SIFT, doubled planes:            {:.3} s ({n} keypoints), speed-up {:.2}x",
            t,
            cv_s / t
        );
    }
    Ok(())
}

/// A temporary file path removed on cleanup.
struct TmpPath(PathBuf);

impl TmpPath {
    fn cleanup(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

fn tempfile_path() -> anyhow::Result<TmpPath> {
    let p = std::env::temp_dir().join(format!("mosaicd_bench_sift_{}.u16", std::process::id()));
    Ok(TmpPath(p))
}
