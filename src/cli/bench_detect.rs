//! `mosaicd bench detect`: our multi-scale detector (HOG, or ACF with an ACF `--model`) on a 1080p
//! 12-bit mosaic vs OpenCV (cvtColor Bayer→BGR + `HOGDescriptor.detectMultiScale`) in the same
//! run, same thread count, same smallest person height (both 64x128 windows from the frame's own
//! scale, down to a window the size of the frame). The output names the kernel path and the CPU's
//! features ([`mosaicd::kernels::describe`]; `MOSAICD_KERNELS` forces a path), as does the JSON
//! (`kernels`). The timed loop is [`mosaicd::eval::time_detector`].

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

use anyhow::{bail, Context};
use mosaicd::detect::AcfOptions;
use mosaicd::detect::{DetectStats, DetectorOptions, Domain, StageProfile};
use mosaicd::detect::{PeopleDetector, PeopleModel, PeopleStats};
use mosaicd::eval::time_detector;
use mosaicd::features::hog::{HogInput, MosaicTone};
use mosaicd::progress::Progress;
use mosaicd::raw::Gains;
use mosaicd::raw::{load_headerless, Cfa, Container, Endian, Levels, RawFormat};

use super::detect_common::SvmArg;

/// The OpenCV peer: reads the raw u16 file, times demosaic (+ 16→8 bit) and detectMultiScale.
const PEER: &str = r#"
import json, sys, time
import cv2, numpy as np
path, w, h, bits, code, frames, threads, scale, levels = sys.argv[1:10]
w, h, bits, frames, threads, scale, levels = int(w), int(h), int(bits), int(frames), int(threads), float(scale), int(levels)
cv2.setNumThreads(threads)
m = np.fromfile(path, dtype='<u2', count=w*h).reshape(h, w)
hog = cv2.HOGDescriptor((64,128),(16,16),(8,8),(8,8),9,1,-1,cv2.HOGDescriptor_L2Hys,0.2,True,levels)
hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
conv = getattr(cv2, 'COLOR_' + code + '2BGR')
dem, det, n = [], [], 0
for i in range(frames + 1):
    t0 = time.perf_counter()
    bgr = cv2.convertScaleAbs(cv2.cvtColor(m, conv), alpha=1.0 / (1 << (bits - 8)))
    t1 = time.perf_counter()
    rects, weights = hog.detectMultiScale(bgr, hitThreshold=0, winStride=(8, 8), padding=(0, 0), scale=scale)
    t2 = time.perf_counter()
    if i > 0:
        dem.append(t1 - t0); det.append(t2 - t1)
    n = len(rects)
print(json.dumps({"opencv": cv2.__version__, "demosaic_s": sum(dem)/len(dem), "detect_s": sum(det)/len(det), "boxes": n}))
"#;

/// Arguments of `mosaicd bench detect`.
#[derive(clap::Args, Debug)]
pub struct BenchDetectArgs {
    /// Raw mosaic (headerless little-endian u16). Default: $MOSAICD_DATA/raw/openisp/test.RAW
    /// (1920x1080 RGGB 10-bit, promoted to a 12-bit container by x4).
    #[arg(long)]
    pub raw: Option<PathBuf>,
    /// Width of --raw.
    #[arg(long, default_value_t = 1920)]
    pub width: usize,
    /// Height of --raw.
    #[arg(long, default_value_t = 1080)]
    pub height: usize,
    /// Bit depth the frame is benchmarked at.
    #[arg(long, default_value_t = 12)]
    pub bit_depth: u8,
    /// Left shift applied to the file's samples to reach --bit-depth (2: 10-bit file → 12-bit).
    #[arg(long, default_value_t = 2)]
    pub shift: u8,
    /// CFA pattern of --raw.
    #[arg(long, default_value = "RGGB")]
    pub cfa: Cfa,
    /// Timed frames (after one warm-up frame) for each side.
    #[arg(long, default_value_t = 10)]
    pub frames: usize,
    /// Threads for each side (our own rayon pool; cv2.setNumThreads for OpenCV).
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Pyramid scale step (both sides).
    #[arg(long, default_value_t = 1.05)]
    pub scale_step: f64,
    /// Maximum pyramid levels (both sides).
    #[arg(long, default_value_t = 64)]
    pub max_levels: usize,
    /// Feature-pyramid approximation for our side (1 = exact; see `mosaicd detect --approx`;
    /// default the daemon's).
    #[arg(long, default_value_t = mosaicd::detect::DEFAULT_APPROX_LEVELS)]
    pub approx: usize,
    /// SVM arithmetic for our side (`f32`, `i8` or `auto`; see `mosaicd detect --svm`; default the
    /// daemon's, `auto`).
    #[arg(long, value_enum, default_value_t = SvmArg::Auto)]
    pub svm: SvmArg,
    /// Skip the OpenCV peer.
    #[arg(long)]
    pub no_peer: bool,
    /// Our side's model: `opencv-default` (OpenCV's weights, the same as the peer's; the
    /// default), a built-in name or HOG file, or an ACF model file (e.g. models/acf-mosaic.json:
    /// its own pyramid, greedy suppression, the daemon's ACF options; --scale-step, --approx and
    /// --svm are HOG's).
    #[arg(long, default_value = mosaicd::detect::OPENCV_DEFAULT)]
    pub model: String,
    /// Hit threshold of our side (the peer's is 0).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub threshold: f32,
    /// How the frame becomes the detector's mosaic, overriding the model's tone (OpenCV's weights
    /// read `linear`; `srgb` adds per-site white balance, with grey-world gains since the frame
    /// has none, and the sRGB curve: the daemon's `compute.mosaic_tone = "srgb"`).
    #[arg(long)]
    pub mosaic_tone: Option<MosaicTone>,
    /// Frames of the per-stage profile run after the timed frames: one thread, stages unfused and
    /// timed one by one (gradients, cells, blocks, micro-cells, approximated levels, SVM, NMS).
    /// 0 skips it.
    #[arg(long, default_value_t = 2)]
    pub profile_frames: usize,
    /// Python interpreter for the peer.
    #[arg(long, default_value = "python3")]
    pub python: String,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Run `mosaicd bench detect`.
pub fn run(a: BenchDetectArgs) -> anyhow::Result<()> {
    // the file's samples (`--bit-depth` − `--shift` bits) through the library's headerless loader,
    // then promoted to the benchmarked depth
    let file_bits = a
        .bit_depth
        .checked_sub(a.shift)
        .filter(|b| *b >= 8)
        .with_context(|| {
            format!(
                "--bit-depth {} minus --shift {} must be at least 8",
                a.bit_depth, a.shift
            )
        })?;
    let loaded = match &a.raw {
        Some(p) => {
            let white = ((1u32 << file_bits) - 1) as u16;
            let fmt = RawFormat::new(
                a.width,
                a.height,
                file_bits,
                a.cfa,
                Container::U16,
                Endian::Little,
                Levels::uniform(0, white),
            );
            load_headerless(p, &fmt).with_context(|| format!("--raw {}", p.display()))?
        }
        None => {
            let test = &mosaicd::data::OPENISP_TEST;
            if file_bits != test.bit_depth {
                bail!(
                    "the default frame ({}) is {}-bit: --bit-depth minus --shift must be {} (or give --raw)",
                    test.rel,
                    test.bit_depth,
                    test.bit_depth
                );
            }
            mosaicd::data::load_raw_frame(test)?
        }
    };
    let frame = loaded.promoted(a.shift)?;
    let path = a
        .raw
        .clone()
        .unwrap_or_else(|| PathBuf::from(mosaicd::data::OPENISP_TEST.rel));

    let model = PeopleModel::load(&a.model, Domain::Mosaic)?.with_overrides(None, a.mosaic_tone);
    let opts = DetectorOptions {
        scale_step: a.scale_step,
        max_levels: a.max_levels,
        approx_levels: a.approx,
        svm: a.svm.into(),
        hit_threshold: a.threshold,
        ..Default::default()
    };
    // the daemon's ACF options (greedy suppression, the model's pyramid)
    let acf_opts = AcfOptions {
        max_levels: a.max_levels,
        hit_threshold: a.threshold,
        ..AcfOptions::default()
    };
    let det = model.build(&opts, &acf_opts)?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(a.threads).build()?;
    // the mosaic buffer is reused between frames, as the daemon's pooled buffers are
    let strip_rows = mosaicd::pipeline::StageSpec::default().strip_rows;
    let bar = Progress::new("bench detect", Some(a.frames as u64 + 1));
    let timed = pool.install(|| {
        time_detector(&det, &frame, Gains::Auto, strip_rows, a.frames, &mut |i| {
            bar.set(i as u64, "ours")
        })
    })?;
    bar.finish();
    let f = timed.len().max(1) as f64;
    let sum = |g: &dyn Fn(&mosaicd::eval::TimedFrame) -> Duration| timed.iter().map(g).sum::<Duration>();
    let (norm, total) = (sum(&|t| t.normalise), sum(&|t| t.total));
    let ours_s = total.as_secs_f64() / f;
    let last = timed.last().context("--frames 0: nothing timed")?;
    let (levels, windows, boxes) = (last.stats.levels(), last.stats.windows(), last.boxes);
    let stages = stage_ms(&timed, norm);
    let tone = det.mosaic_tone().name();
    let win = det.window();

    // Per-stage CPU (HOG): the production path fuses gradients, cells and blocks and overlaps
    // levels, so its stage clocks are summed wall times of overlapping sections. One thread,
    // unfused.
    let profile = match &det {
        PeopleDetector::Hog(hog) if a.profile_frames > 0 => {
            let pool1 = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
            let prep = det.mosaic_prep(Gains::Auto);
            let mut p = StageProfile::default();
            for _ in 0..a.profile_frames {
                p += pool1
                    .install(|| -> anyhow::Result<_> {
                        let m = prep.mosaic(&frame)?;
                        Ok(hog.stage_profile(&HogInput::Mosaic(m.view()))?)
                    })?
                    .1;
            }
            let n = a.profile_frames as f64;
            Some(serde_json::json!({
                "resize": ms(p.resize) / n, "gradients": ms(p.gradients) / n, "cells": ms(p.cells) / n,
                "blocks": ms(p.blocks) / n, "micro_cells": ms(p.micro_cells) / n,
                "approx_cells_blocks": ms(p.approx_cells_blocks) / n, "svm": ms(p.svm) / n, "nms": ms(p.nms) / n,
                "total": ms(p.total()) / n,
            }))
        }
        _ => None,
    };

    let peer = if a.no_peer {
        None
    } else {
        let tmp = tempfile_path()?;
        let raw_bytes: Vec<u8> = frame.to_u16_vec().iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(&tmp, raw_bytes)?;
        let out = Command::new(&a.python)
            .args(["-c", PEER])
            .arg(&tmp)
            .args([
                frame.width().to_string(),
                frame.height().to_string(),
                a.bit_depth.to_string(),
                frame.cfa().opencv_code_name().to_string(),
                a.frames.max(1).to_string(),
                a.threads.to_string(),
                a.scale_step.to_string(),
                a.max_levels.to_string(),
            ])
            .output()
            .with_context(|| format!("running {}", a.python))?;
        let _ = std::fs::remove_file(&tmp);
        if !out.status.success() {
            bail!("OpenCV peer failed: {}", String::from_utf8_lossy(&out.stderr));
        }
        let v: serde_json::Value = serde_json::from_slice(&out.stdout)?;
        Some(v)
    };
    let commit = Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    let peer_s = peer
        .as_ref()
        .map(|p| p["demosaic_s"].as_f64().unwrap_or(0.0) + p["detect_s"].as_f64().unwrap_or(0.0));
    let report = serde_json::json!({
        "input": path.display().to_string(), "width": frame.width(), "height": frame.height(), "bit_depth": a.bit_depth,
        "cfa": frame.cfa().name(), "threads": a.threads, "frames": a.frames, "commit": commit,
        "kernels": super::bench_gradients::kernels_json(),
        "detector": det.kind().name(), "model": a.model, "mosaic_tone": tone, "threshold": a.threshold,
        "smallest_window": [win.0, win.1],
        "scale_step": a.scale_step, "approx_levels": a.approx, "svm": opts.svm.name(), "max_levels": a.max_levels, "levels": levels, "windows": windows,
        "ours": {
            "fps": 1.0 / ours_s, "frame_ms": ours_s * 1e3, "boxes": boxes,
            "stage_ms_per_frame": stages,
            "stage_cpu_ms_per_frame_1_thread_unfused": profile,
        },
        "opencv": peer.as_ref().map(|p| serde_json::json!({
            "version": p["opencv"], "fps": 1.0 / peer_s.unwrap_or(f64::NAN),
            "demosaic_ms": p["demosaic_s"].as_f64().unwrap_or(0.0) * 1e3,
            "detect_ms": p["detect_s"].as_f64().unwrap_or(0.0) * 1e3, "boxes": p["boxes"],
        })),
        "speedup": peer_s.map(|p| p / ours_s),
    });
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        let pyramid = match &det {
            PeopleDetector::Hog(_) => format!(
                "scale {} x {} levels (used {levels}), approx {}, svm {}",
                a.scale_step, a.max_levels, a.approx, opts.svm
            ),
            PeopleDetector::Acf(d) => {
                let p = d.pyramid_options();
                format!(
                    "acf {} levels per octave ({} approximated between exact ones; used {levels}), the peer scale {} x {} levels",
                    p.per_octave, p.approx, a.scale_step, a.max_levels
                )
            }
        };
        println!(
            "bench detect: {}x{} {}-bit {} mosaic, {} threads each, {} detector ({}, {tone} tone), {pyramid}, {windows} windows/frame, smallest window {}x{} both sides, commit {commit}",
            frame.width(),
            frame.height(),
            a.bit_depth,
            frame.cfa().name(),
            a.threads,
            det.kind(),
            a.model,
            win.0,
            win.1,
        );
        println!("  {}", mosaicd::kernels::describe());
        println!(
            "  mosaicd : {:7.1} ms/frame  {:6.2} fps  ({} boxes)",
            ours_s * 1e3,
            1.0 / ours_s,
            boxes
        );
        let st = &report["ours"]["stage_ms_per_frame"];
        println!("    stages (summed section clocks, ms/frame): {st}");
        let pr = &report["ours"]["stage_cpu_ms_per_frame_1_thread_unfused"];
        if !pr.is_null() {
            println!(
                "    stages (CPU ms/frame, 1 thread, unfused, {} frames): {pr}",
                a.profile_frames
            );
        }
        if let (Some(p), Some(ps)) = (&peer, peer_s) {
            println!(
                "  OpenCV {}: {:7.1} ms/frame  {:6.2} fps  (cvtColor {:.1} ms + detectMultiScale {:.1} ms, {} boxes)",
                p["opencv"],
                ps * 1e3,
                1.0 / ps,
                p["demosaic_s"].as_f64().unwrap_or(0.0) * 1e3,
                p["detect_s"].as_f64().unwrap_or(0.0) * 1e3,
                p["boxes"]
            );
            println!("  speed-up: {:.2}x", ps / ours_s);
        }
    }
    Ok(())
}

/// Each stage's clock summed over its sections, per frame. HOG: levels overlap, so this is close
/// to CPU but not exact; exact levels fuse gradients, cells and blocks (and the group's
/// micro-cell pooling). ACF: channel pyramid and scoring wall times, and the trees per window.
fn stage_ms(timed: &[mosaicd::eval::TimedFrame], norm: Duration) -> serde_json::Value {
    let f = timed.len().max(1) as f64;
    let mut hog = DetectStats::default();
    let (mut channels, mut score, mut nms, mut trees, mut windows) =
        (Duration::ZERO, Duration::ZERO, Duration::ZERO, 0u64, 0u64);
    for t in timed {
        match &t.stats {
            PeopleStats::Hog(s) => hog += s.clone(),
            PeopleStats::Acf(s) => {
                channels += s.channels;
                score += s.score;
                nms += s.nms;
                trees += s.trees_evaluated;
                windows += s.windows as u64;
            }
        }
    }
    match timed.first().map(|t| &t.stats) {
        Some(PeopleStats::Acf(_)) => serde_json::json!({
            "normalise": ms(norm) / f, "channels": ms(channels) / f, "score": ms(score) / f,
            "nms": ms(nms) / f, "trees_per_window": trees as f64 / windows.max(1) as f64,
        }),
        _ => serde_json::json!({
            "normalise": ms(norm) / f, "resize": ms(hog.resize) / f,
            "exact_levels": ms(hog.hog.cells + hog.hog.blocks) / f,
            "approx_levels": ms(hog.cell_resample) / f, "svm": ms(hog.svm) / f, "nms": ms(hog.nms) / f,
        }),
    }
}

fn tempfile_path() -> anyhow::Result<PathBuf> {
    let dir = std::env::temp_dir();
    Ok(dir.join(format!("mosaicd-bench-detect-{}.raw", std::process::id())))
}
