//! `mosaicd gradients INPUT [input flags] --operator central|sobel --out DIR [--grey-baseline]`:
//! gradient maps of one frame as PNG files, computed by the fused mosaic kernel the daemon uses.
//!
//! Writes into `--out`:
//! * `magnitude.png` — 8-bit, `min(255, round(255 · m / m_p99.5))`: the magnitude divided by its
//!   99.5th percentile (a robust maximum, so a few hot pixels do not turn the map black).
//! * `magnitude16.png` — 16-bit, the fused kernel's exact `u16` magnitude (raw units / 2^shift).
//! * `orientation.png` — RGB: hue = orientation bin (signed 0–360° by default here, so opposite
//!   edges get opposite colours), value = the normalised magnitude.
//! * with `--grey-baseline` and an RGB input: `grey_magnitude.png` — the same operator on the grey
//!   image (RGB → BT.601 grey), normalised with the **same** scale as `magnitude.png`, so the two can
//!   be compared side by side.
//!
//! Prints one line: size, bit depth, pattern, operator, time, min/max/mean magnitude.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};

use super::input::InputArgs;

use mosaicd::features::gradient::{mag_bin, AngleRange, Border, MagBinOptions, MagBinSpec, Operator};
use mosaicd::image::Image;
use mosaicd::isp::grey_from_rgb_u8;
use mosaicd::raw::RawView;

/// Percentile of the magnitude mapped to full scale in the 8-bit PNGs.
const NORM_PERCENTILE: f64 = 0.995;
/// Orientation bins of the visualisation (10° each over 0–360°).
const VIS_BINS: usize = 36;

/// Arguments of `mosaicd gradients`.
#[derive(clap::Args, Debug)]
pub struct GradientsArgs {
    /// The input frame and how to read it (shared with `detect` and `sift`).
    #[command(flatten)]
    pub input: InputArgs,
    /// Derivative operator.
    #[arg(long, default_value = "central")]
    pub operator: Operator,
    /// Border handling.
    #[arg(long, value_enum, default_value = "reflect101")]
    pub border: BorderArg,
    /// Output directory (created).
    #[arg(long, default_value = "out/gradients")]
    pub out: PathBuf,
    /// Also write the grey-image baseline (RGB inputs only).
    #[arg(long)]
    pub grey_baseline: bool,
}

/// `--border` values.
#[derive(clap::ValueEnum, Debug, Clone, Copy)]
pub enum BorderArg {
    /// OpenCV BORDER_REFLECT_101 (colour-preserving, zero across the edge).
    Reflect101,
    /// OpenCV BORDER_REPLICATE (mixes colours at the edge on a mosaic).
    Replicate,
    /// Same-colour linear extrapolation (keeps colour and gradient).
    MosaicExtrapolate,
}

impl From<BorderArg> for Border {
    fn from(b: BorderArg) -> Border {
        match b {
            BorderArg::Reflect101 => Border::Reflect101,
            BorderArg::Replicate => Border::Replicate,
            BorderArg::MosaicExtrapolate => Border::MosaicExtrapolate,
        }
    }
}

/// Value of the `p`-quantile of `v` (at least 1, so it can divide).
fn percentile(v: &[u16], p: f64) -> u16 {
    let mut hist = vec![0u64; 65536];
    for &x in v {
        hist[x as usize] += 1;
    }
    let target = (p * v.len() as f64).ceil() as u64;
    let mut acc = 0;
    for (i, &c) in hist.iter().enumerate() {
        acc += c;
        if acc >= target {
            return (i as u16).max(1);
        }
    }
    1
}

fn to_u8(v: &[u16], scale: u16) -> Vec<u8> {
    v.iter()
        .map(|&m| ((m as u32 * 255 + scale as u32 / 2) / scale as u32).min(255) as u8)
        .collect()
}

/// HSV (h in degrees, s = 1, v in 0..=1) → RGB.
fn hsv(h: f32, v: f32) -> [u8; 3] {
    let c = v;
    let hp = h / 60.0;
    let x = c * (1.0 - (hp % 2.0 - 1.0).abs());
    let (r, g, b) = match hp as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    [(r * 255.0) as u8, (g * 255.0) as u8, (b * 255.0) as u8]
}

fn save_l8(path: &Path, w: usize, h: usize, data: Vec<u8>) -> anyhow::Result<()> {
    image::GrayImage::from_raw(w as u32, h as u32, data)
        .context("buffer size")?
        .save(path)
        .with_context(|| format!("writing {}", path.display()))
}

/// Run `mosaicd gradients`.
pub fn run(args: GradientsArgs) -> anyhow::Result<()> {
    let loaded = args.input.load()?;
    let f = &loaded.frame;
    let (w, h) = (f.width(), f.height());
    let spec = MagBinSpec::new(MagBinOptions {
        operator: args.operator,
        border: args.border.into(),
        bins: VIS_BINS,
        range: AngleRange::Signed,
        serial: false,
    })?;
    let mut mag = Image::<u16>::new(w, h);
    let mut bin = Image::<u8>::new(w, h);
    let t = Instant::now();
    mag_bin(
        f.view(),
        f.bit_depth(),
        &spec,
        &mut mag.view_mut(),
        &mut bin.view_mut(),
    )?;
    let ms = t.elapsed().as_secs_f64() * 1e3;

    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let scale = percentile(mag.as_slice(), NORM_PERCENTILE);
    let m8 = to_u8(mag.as_slice(), scale);
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(w as u32, h as u32, mag.as_slice().to_vec())
        .context("buffer size")?
        .save(args.out.join("magnitude16.png"))
        .context("writing magnitude16.png")?;
    let mut rgb = Vec::with_capacity(w * h * 3);
    for (&b, &m) in bin.as_slice().iter().zip(&m8) {
        let hue = (b as f32 + 0.5) * (360.0 / VIS_BINS as f32);
        rgb.extend_from_slice(&hsv(hue, m as f32 / 255.0));
    }
    save_l8(&args.out.join("magnitude.png"), w, h, m8)?;
    image::RgbImage::from_raw(w as u32, h as u32, rgb)
        .context("buffer size")?
        .save(args.out.join("orientation.png"))
        .context("writing orientation.png")?;

    let s = mag.as_slice();
    let (min, max) = (
        s.iter().min().copied().unwrap_or(0),
        s.iter().max().copied().unwrap_or(0),
    );
    let mean = s.iter().map(|&v| v as f64).sum::<f64>() / s.len().max(1) as f64;
    let shift = spec.mag_shift(f.bit_depth());
    println!(
        "gradients: {w}x{h} {}-bit {} operator={:?} border={:?}: {ms:.2} ms ({} threads); magnitude (raw units{}) min {min} max {max} mean {mean:.2}; p99.5 {scale} -> {}",
        f.bit_depth(),
        f.cfa().name(),
        args.operator,
        Border::from(args.border),
        rayon::current_num_threads(),
        if shift > 0 { format!(" / 2^{shift}") } else { String::new() },
        args.out.display()
    );

    if args.grey_baseline {
        let Some(rgb) = &loaded.rgb else {
            bail!("--grey-baseline needs an RGB input (PNG/JPEG); this input is already a mosaic");
        };
        let grey = grey_from_rgb_u8(&rgb.view());
        let mut gm = Image::<u16>::new(w, h);
        mag_bin(
            RawView::U8(grey.view()),
            8,
            &spec,
            &mut gm.view_mut(),
            &mut bin.view_mut(),
        )?;
        save_l8(
            &args.out.join("grey_magnitude.png"),
            w,
            h,
            to_u8(gm.as_slice(), scale),
        )?;
        let gs = gm.as_slice();
        let gmean = gs.iter().map(|&v| v as f64).sum::<f64>() / gs.len().max(1) as f64;
        println!(
            "grey baseline: max {} mean {gmean:.2} (same scale as the mosaic map) -> {}",
            gs.iter().max().copied().unwrap_or(0),
            args.out.join("grey_magnitude.png").display()
        );
    }
    Ok(())
}
