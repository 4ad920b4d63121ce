//! `mosaicd bench gradients`: our fused raw → magnitude + orientation-bin kernel against OpenCV's
//! demosaic (bilinear) → grey → `[-1, 0, 1]` → magnitude (and + phase), one thread each, on the same
//! seeded synthetic mosaics, in one run; prints a table with the ratio and the memory-bandwidth
//! floor (a copy of the input plus a write of the 3-byte-per-pixel output).
//!
//! The OpenCV side is `benches/peer_opencv_gradients.py`, run on a temporary `.npy` of the mosaic.

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};

use mosaicd::features::gradient::{
    mag_bin, synthetic_mosaic, KernelPath, MagBinOptions, MagBinSpec, Operator,
};
use mosaicd::image::Image;
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

fn median_ms(repeats: usize, mut f: impl FnMut()) -> f64 {
    f(); // warm-up
    let mut ts: Vec<f64> = (0..repeats.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    ts.sort_by(f64::total_cmp);
    ts[ts.len() / 2]
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
    opencv: String,
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
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let spec = MagBinSpec::new(MagBinOptions {
        operator: args.operator,
        ..Default::default()
    })?;
    let tmp = tempfile_dir()?;
    let commit = commit();
    let mut rows = Vec::new();
    let mut opencv_version = String::new();
    for &(w, h) in &sizes {
        eprintln!("bench gradients: generating {w}x{h} synthetic mosaic (seed {SEED})");
        let m16 = synthetic_mosaic(w, h, 12, SEED);
        for &bits in &args.bits {
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
            let ours = pool.install(|| {
                median_ms(args.repeats, || {
                    mag_bin(src, bits, &spec, &mut mag.view_mut(), &mut bin.view_mut()).expect("valid sizes");
                    std::hint::black_box((&mag, &bin));
                })
            });
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
            rows.push((w, h, bits, ours, peer.mag_ms, peer.mag_phase_ms, floor));
        }
    }
    let _ = std::fs::remove_dir(&tmp);
    println!(
        "mosaicd bench gradients — commit {commit}, OpenCV {opencv_version}, 1 thread each, operator {:?}, {} bins, kernel path {:?}, median of {}",
        args.operator,
        spec.options().bins,
        KernelPath::best(),
        args.repeats
    );
    println!(
        "| size | bits | threads | commit | ours ms (mag+bin) | OpenCV ms (mag) | ratio | OpenCV ms (mag+phase) | ratio | memcpy floor ms | ours / floor |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for (w, h, bits, ours, cv, cvp, floor) in rows {
        println!(
            "| {w}x{h} | {bits} | 1 | {commit} | {ours:.2} | {cv:.2} | {:.1}x | {cvp:.2} | {:.1}x | {floor:.2} | {:.1}x |",
            cv / ours,
            cvp / ours,
            ours / floor
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
