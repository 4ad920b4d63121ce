//! `mosaicd bench gradients`: our fused raw → magnitude + orientation-bin kernel against OpenCV's
//! demosaic (bilinear) → grey → `[-1, 0, 1]` → magnitude (and + phase), with the same number of
//! threads each (`--threads`, default one), on the same seeded synthetic mosaics, in one run;
//! prints a table with the ratio and the memory-bandwidth floor (a copy of the input plus a write
//! of the 3-byte-per-pixel output), headed by the kernel path and the CPU's features
//! ([`mosaicd::kernels::describe`]); `--json` prints the same as one JSON document.
//!
//! The OpenCV side is `benches/peer_opencv_gradients.py`, run on a temporary `.npy` of the mosaic.

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};
use mosaicd::progress::Progress;

use mosaicd::features::gradient::{mag_bin, synthetic_mosaic, MagBinOptions, MagBinSpec, Operator};
use mosaicd::image::Image;
use mosaicd::kernels;
use mosaicd::raw::RawView;

/// Seed of the synthetic scene (same as `benches/gradients.rs`).
const SEED: u64 = 2024;

/// Arguments of `mosaicd bench gradients`.
#[derive(clap::Args, Debug)]
pub struct BenchGradientsArgs {
    /// Frame sizes as WIDTHxHEIGHT (default 1080p and 12 MP).
    #[arg(long, value_delimiter = ',', default_value = "1920x1080,4000x3000")]
    pub sizes: Vec<String>,
    /// Bit depths (8 → u8 container, otherwise u16).
    #[arg(long, value_delimiter = ',', default_value = "8,12")]
    pub bits: Vec<u8>,
    /// Timed repetitions per measurement (median reported).
    #[arg(long, default_value_t = 15)]
    pub repeats: usize,
    /// Threads for each side: ours on a rayon pool of this size, OpenCV with `setNumThreads`.
    /// With one, ratios use the working thread's CPU time; with more, wall time.
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    /// Print one JSON document instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Our operator (OpenCV always runs [-1, 0, 1]).
    #[arg(long, default_value = "central")]
    pub operator: Operator,
    /// Python interpreter with cv2.
    #[arg(long, default_value = "python3")]
    pub python: String,
    /// The OpenCV peer script.
    #[arg(long, default_value = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/peer_opencv_gradients.py"))]
    pub peer: PathBuf,
}

fn parse_size(s: &str) -> anyhow::Result<(usize, usize)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .with_context(|| format!("size {s:?}: expected WIDTHxHEIGHT"))?;
    let (w, h) = (w.trim().parse()?, h.trim().parse()?);
    if w < 4 || h < 4 {
        bail!("size {s:?}: at least 4x4");
    }
    Ok((w, h))
}

/// CPU time of `clock` (`CLOCK_THREAD_CPUTIME_ID` or `CLOCK_PROCESS_CPUTIME_ID`) in ms.
fn cpu_ms(clock: libc::clockid_t) -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; both CPU-time clocks are supported on Linux.
    let rc = unsafe { libc::clock_gettime(clock, &mut ts) };
    debug_assert_eq!(rc, 0);
    ts.tv_sec as f64 * 1e3 + ts.tv_nsec as f64 * 1e-6
}

/// Medians of one measurement, in ms.
#[derive(Debug, Clone, Copy, serde::Serialize)]
struct Times {
    /// Wall time.
    wall_ms: f64,
    /// CPU time of the calling (working) thread.
    thread_cpu_ms: f64,
    /// CPU time of the whole process (every worker thread).
    process_cpu_ms: f64,
}

/// Median wall, thread-CPU and process-CPU time of `f`. On a shared machine the CPU times leave
/// out the time other processes ran; with one thread the thread's is the fair measure of the work.
fn median_ms(repeats: usize, mut f: impl FnMut()) -> Times {
    f(); // warm-up
    let mut v: [Vec<f64>; 3] = Default::default();
    for _ in 0..repeats.max(1) {
        let (c, p) = (
            cpu_ms(libc::CLOCK_THREAD_CPUTIME_ID),
            cpu_ms(libc::CLOCK_PROCESS_CPUTIME_ID),
        );
        let t = Instant::now();
        f();
        v[0].push(t.elapsed().as_secs_f64() * 1e3);
        v[1].push(cpu_ms(libc::CLOCK_THREAD_CPUTIME_ID) - c);
        v[2].push(cpu_ms(libc::CLOCK_PROCESS_CPUTIME_ID) - p);
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Times {
        wall_ms: med(&mut v[0]),
        thread_cpu_ms: med(&mut v[1]),
        process_cpu_ms: med(&mut v[2]),
    }
}

impl Times {
    /// The time ratios are taken from: the thread's CPU with one thread, wall time with more.
    fn basis(&self, threads: usize) -> f64 {
        if threads == 1 {
            self.thread_cpu_ms
        } else {
            self.wall_ms
        }
    }

    /// The work: the thread's CPU with one thread, the process's (every thread) with more.
    fn cpu(&self, threads: usize) -> f64 {
        if threads == 1 {
            self.thread_cpu_ms
        } else {
            self.process_cpu_ms
        }
    }
}

/// The kernel path and CPU features, for the JSON of every `bench` command.
pub fn kernels_json() -> serde_json::Value {
    serde_json::json!({
        "path": kernels::isa().name(),
        "cpu_features": kernels::features().names(),
        "describe": kernels::describe(),
    })
}

/// A `.npy` (version 1) of a 2-D u8 or u16 array.
fn npy_bytes(descr: &str, w: usize, h: usize, data: &[u8]) -> Vec<u8> {
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': ({h}, {w}), }}");
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + data.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(data);
    out
}

/// `git rev-parse --short HEAD`, with `+dirty` when the worktree has uncommitted changes.
fn commit() -> String {
    let git = |args: &[&str]| {
        Command::new("git")
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let head = git(&["rev-parse", "--short", "HEAD"]).unwrap_or_else(|| "unknown".into());
    match git(&["status", "--porcelain", "--untracked-files=no"]) {
        Some(s) if !s.is_empty() => format!("{head}+dirty"),
        _ => head,
    }
}

#[derive(serde::Deserialize)]
struct Peer {
    mag_ms: f64,
    mag_phase_ms: f64,
    mag_cpu_ms: f64,
    mag_phase_cpu_ms: f64,
    mag_proc_cpu_ms: f64,
    mag_phase_proc_cpu_ms: f64,
    opencv: String,
}

/// One row of the table.
#[derive(serde::Serialize)]
struct Row {
    width: usize,
    height: usize,
    bits: u8,
    ours: Times,
    opencv_mag: Times,
    opencv_mag_phase: Times,
    floor: Times,
    ratio_mag: f64,
    ratio_mag_phase: f64,
    ours_over_floor: f64,
}

/// Run `mosaicd bench gradients`.
pub fn run(args: BenchGradientsArgs) -> anyhow::Result<()> {
    let sizes: Vec<(usize, usize)> = args
        .sizes
        .iter()
        .map(|s| parse_size(s))
        .collect::<anyhow::Result<_>>()?;
    if let Some(b) = args.bits.iter().find(|b| !(8..=16).contains(*b)) {
        bail!("bit depth {b} outside 8..=16");
    }
    anyhow::ensure!(args.threads >= 1, "--threads must be at least 1");
    let threads = args.threads;
    // One thread: the serial option runs every strip on this (the timing) thread. More: row
    // strips on a pool of that size, as the daemon runs the kernel.
    let spec = MagBinSpec::new(MagBinOptions {
        operator: args.operator,
        serial: threads == 1,
        ..Default::default()
    })?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
    let tmp = tempfile_dir()?;
    let commit = commit();
    let mut rows = Vec::new();
    let mut opencv_version = String::new();
    let bar = Progress::new("bench gradients", Some((sizes.len() * args.bits.len()) as u64));
    for (k, &(w, h)) in sizes.iter().enumerate() {
        bar.println(&format!(
            "bench gradients: generating {w}x{h} synthetic mosaic (seed {SEED})"
        ));
        let m16 = synthetic_mosaic(w, h, 12, SEED);
        for (j, &bits) in args.bits.iter().enumerate() {
            bar.set((k * args.bits.len() + j) as u64, &format!("{w}x{h} {bits}-bit"));
            let (m8, m16b);
            let (src, raw_bytes, descr): (RawView<'_>, Vec<u8>, &str) = if bits == 8 {
                m8 = m16.map(|v| (v >> 4) as u8);
                (RawView::U8(m8.view()), m8.as_slice().to_vec(), "|u1")
            } else {
                m16b = m16.map(|v| ((v as u32) << bits >> 12).min((1u32 << bits) - 1) as u16);
                let bytes = m16b.as_slice().iter().flat_map(|v| v.to_le_bytes()).collect();
                (RawView::U16(m16b.view()), bytes, "<u2")
            };
            let mut mag = Image::<u16>::new(w, h);
            let mut bin = Image::<u8>::new(w, h);
            let mut kernel =
                || mag_bin(src, bits, &spec, &mut mag.view_mut(), &mut bin.view_mut()).expect("valid sizes");
            let ours = median_ms(args.repeats, || {
                // One thread: serial, on this (the timing) thread; more: on the pool.
                if threads == 1 {
                    kernel()
                } else {
                    pool.install(&mut kernel)
                }
            });
            std::hint::black_box((&mag, &bin));
            let mut in_copy = vec![0u8; raw_bytes.len()];
            let out_src = vec![1u8; w * h * 3];
            let mut out_copy = vec![0u8; w * h * 3];
            let floor = median_ms(args.repeats, || {
                in_copy.copy_from_slice(std::hint::black_box(&raw_bytes));
                out_copy.copy_from_slice(std::hint::black_box(&out_src));
                std::hint::black_box((&in_copy, &out_copy));
            });
            let npy = tmp.join(format!("mosaic_{w}x{h}_{bits}.npy"));
            std::fs::write(&npy, npy_bytes(descr, w, h, &raw_bytes))?;
            let out = Command::new(&args.python)
                .arg(&args.peer)
                .arg("--npy")
                .arg(&npy)
                .args(["--cfa", "RGGB", "--repeats", &args.repeats.to_string()])
                .args(["--threads", &threads.to_string()])
                .output()
                .with_context(|| format!("running {} {}", args.python, args.peer.display()))?;
            let _ = std::fs::remove_file(&npy);
            if !out.status.success() {
                bail!(
                    "OpenCV peer failed ({}): {}",
                    out.status,
                    String::from_utf8_lossy(&out.stderr).trim()
                );
            }
            let peer: Peer = serde_json::from_slice(&out.stdout)
                .with_context(|| format!("peer output: {}", String::from_utf8_lossy(&out.stdout)))?;
            opencv_version = peer.opencv.clone();
            let cv = Times {
                wall_ms: peer.mag_ms,
                thread_cpu_ms: peer.mag_cpu_ms,
                process_cpu_ms: peer.mag_proc_cpu_ms,
            };
            let cvp = Times {
                wall_ms: peer.mag_phase_ms,
                thread_cpu_ms: peer.mag_phase_cpu_ms,
                process_cpu_ms: peer.mag_phase_proc_cpu_ms,
            };
            rows.push(Row {
                width: w,
                height: h,
                bits,
                ratio_mag: cv.basis(threads) / ours.basis(threads),
                ratio_mag_phase: cvp.basis(threads) / ours.basis(threads),
                ours_over_floor: ours.cpu(threads) / floor.thread_cpu_ms,
                ours,
                opencv_mag: cv,
                opencv_mag_phase: cvp,
                floor,
            });
        }
    }
    let _ = std::fs::remove_dir(&tmp);
    if args.json {
        let report = serde_json::json!({
            "commit": commit, "opencv": opencv_version, "threads": threads,
            "operator": format!("{:?}", args.operator), "bins": spec.options().bins,
            "repeats": args.repeats, "kernels": kernels_json(), "rows": rows,
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!(
        "mosaicd bench gradients — commit {commit}, OpenCV {opencv_version}, {threads} thread(s) each, operator {:?}, {} bins, median of {}",
        args.operator,
        spec.options().bins,
        args.repeats
    );
    println!("{}", kernels::describe());
    if threads == 1 {
        println!("times: median wall ms / median CPU ms of the working thread; ratios from CPU time (the machine may be shared)");
    } else {
        println!("times: median wall ms / median process CPU ms (all threads); ratios from wall time; ours / floor from CPU (the floor: one thread)");
    }
    println!(
        "| size | bits | threads | path | commit | ours (mag+bin) | OpenCV (mag) | ratio | OpenCV (mag+phase) | ratio | memcpy floor | ours / floor |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let cell = |t: &Times| format!("{:.2} / {:.2}", t.wall_ms, t.cpu(threads));
    let path = kernels::isa();
    for r in rows {
        println!(
            "| {}x{} | {} | {threads} | {path} | {commit} | {} | {} | {:.1}x | {} | {:.1}x | {:.2} / {:.2} | {:.1}x |",
            r.width,
            r.height,
            r.bits,
            cell(&r.ours),
            cell(&r.opencv_mag),
            r.ratio_mag,
            cell(&r.opencv_mag_phase),
            r.ratio_mag_phase,
            r.floor.wall_ms,
            r.floor.thread_cpu_ms,
            r.ours_over_floor
        );
    }
    Ok(())
}

/// A fresh private temporary directory.
fn tempfile_dir() -> anyhow::Result<PathBuf> {
    let d = std::env::temp_dir().join(format!("mosaicd-bench-gradients-{}", std::process::id()));
    std::fs::create_dir_all(&d).with_context(|| format!("creating {}", d.display()))?;
    Ok(d)
}
