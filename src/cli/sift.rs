//! `mosaicd sift FILE`: SIFT keypoints of one frame, as JSON and as a picture.
//!
//! ```text
//! mosaicd sift DSC_1339_768x512_rggb.raw --width 768 --height 512 --bit-depth 14 --cfa RGGB \
//!     --black 600 --white 15520 --json out/sift.json --picture out/sift.png
//! mosaicd sift kodim09.png --as grey --json out/kodim09.json      # OpenCV-equivalent grey SIFT
//! ```

use std::path::PathBuf;

use anyhow::Context;
use serde::Serialize;

use super::input::InputArgs;
use mosaicd::features::sift::{
    detect_and_compute, normalised_mosaic_from_frame, Domain, Keypoint, SiftFeatures, SiftOptions,
};
use mosaicd::image::Image;

/// Which image SIFT runs on.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SiftDomainArg {
    /// The raw mosaic (the paper's mosaic SIFT; no demosaicing).
    Mosaic,
    /// Grey of an RGB input, `0.299 R + 0.587 G + 0.114 B` (OpenCV-equivalent SIFT).
    Grey,
}

/// Arguments of `mosaicd sift`.
#[derive(clap::Args, Debug)]
pub struct SiftArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Run on the mosaic (default) or on the grey of an RGB input.
    #[arg(long = "as", value_enum, default_value = "mosaic")]
    pub domain: SiftDomainArg,
    /// Double the image (each colour plane for a mosaic) first; default: yes for grey, no for mosaic.
    #[arg(long)]
    pub double: Option<bool>,
    /// Octave step: centred 2x2 means (true) or every other sample as OpenCV (false); default:
    /// centred for the mosaic, OpenCV's for grey.
    #[arg(long)]
    pub centred_octaves: Option<bool>,
    /// Contrast threshold (OpenCV `contrastThreshold`).
    #[arg(long, default_value_t = 0.04)]
    pub contrast_threshold: f64,
    /// Edge threshold (OpenCV `edgeThreshold`).
    #[arg(long, default_value_t = 10.0)]
    pub edge_threshold: f64,
    /// Write keypoints (and descriptors with --descriptors) as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Include the 128-byte descriptors in the JSON.
    #[arg(long)]
    pub descriptors: bool,
    /// Write a picture of the keypoints (circle of radius size/2 and orientation) here.
    #[arg(long)]
    pub picture: Option<PathBuf>,
    /// Worker threads (own rayon pool; 0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

#[derive(Serialize)]
struct Output<'a> {
    input: String,
    domain: Domain,
    width: usize,
    height: usize,
    count: usize,
    seconds: f64,
    keypoints: &'a [Keypoint],
    #[serde(skip_serializing_if = "Option::is_none")]
    descriptors: Option<Vec<Vec<u8>>>,
}

/// Run `mosaicd sift`.
pub fn run(args: SiftArgs) -> anyhow::Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()?;
    let loaded = args.input.load()?;
    let (img, domain) = match args.domain {
        SiftDomainArg::Mosaic => (normalised_mosaic_from_frame(&loaded.frame), Domain::Mosaic),
        SiftDomainArg::Grey => {
            let rgb = loaded
                .rgb
                .as_ref()
                .context("--as grey needs an RGB input (PNG/JPEG); use --as mosaic for raw data")?;
            let g = Image::from_fn(rgb.width(), rgb.height(), |x, y| {
                let [r, g, b] = rgb.get(x, y);
                (0.299 * r as f32 + 0.587 * g as f32 + 0.114 * b as f32).round() / 255.0
            });
            (g, Domain::Grey)
        }
    };
    let mut opts = match domain {
        Domain::Mosaic => SiftOptions::mosaic(),
        Domain::Grey => SiftOptions::grey(),
    };
    opts.max_value = 1.0;
    opts.contrast_threshold = args.contrast_threshold;
    opts.edge_threshold = args.edge_threshold;
    if let Some(d) = args.double {
        opts.double_image = d;
    }
    if let Some(c) = args.centred_octaves {
        opts.centred_octaves = c;
    }
    let spec = opts.build()?;
    let t0 = std::time::Instant::now();
    let f = pool.install(|| detect_and_compute(img.view(), &spec))?;
    let seconds = t0.elapsed().as_secs_f64();
    eprintln!(
        "sift: {} keypoints on a {}x{} {:?} image in {:.3} s ({} threads)",
        f.keypoints.len(),
        img.width(),
        img.height(),
        domain,
        seconds,
        pool.current_num_threads()
    );
    if let Some(p) = &args.json {
        let out = Output {
            input: args.input.input.display().to_string(),
            domain,
            width: img.width(),
            height: img.height(),
            count: f.keypoints.len(),
            seconds,
            keypoints: &f.keypoints,
            descriptors: args
                .descriptors
                .then(|| f.descriptors.iter().map(|d| d.to_vec()).collect()),
        };
        write_parent(p)?;
        std::fs::write(p, serde_json::to_string(&out)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    if let Some(p) = &args.picture {
        write_parent(p)?;
        picture(&img, &f)
            .save(p)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    if args.json.is_none() && args.picture.is_none() {
        for k in &f.keypoints {
            println!(
                "{:.2} {:.2} {:.2} {:.1} {:.4}",
                k.x, k.y, k.size, k.angle, k.response
            );
        }
    }
    Ok(())
}

fn write_parent(p: &std::path::Path) -> anyhow::Result<()> {
    if let Some(d) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d)?;
    }
    Ok(())
}

/// The image on [0, 1] shown with a square-root tone curve, keypoints drawn on top.
fn picture(img: &Image<f32>, f: &SiftFeatures) -> image::RgbImage {
    let mut canvas = image::RgbImage::from_fn(img.width() as u32, img.height() as u32, |x, y| {
        let v = (img.get(x as usize, y as usize).clamp(0.0, 1.0).sqrt() * 255.0) as u8;
        image::Rgb([v, v, v])
    });
    let c = image::Rgb([255, 220, 0]);
    for k in &f.keypoints {
        let r = (k.size as f64 * 0.5).max(1.5);
        let (x, y) = (k.x as f64, k.y as f64);
        let n = ((r * 6.3).ceil() as usize).max(8);
        for i in 0..n {
            let a0 = i as f64 / n as f64 * std::f64::consts::TAU;
            let a1 = (i + 1) as f64 / n as f64 * std::f64::consts::TAU;
            super::eval_sift::draw_line(
                &mut canvas,
                (x + r * a0.cos(), y + r * a0.sin()),
                (x + r * a1.cos(), y + r * a1.sin()),
                c,
            );
        }
        // OpenCV angles are counter-clockwise with y up.
        let a = (k.angle as f64).to_radians();
        super::eval_sift::draw_line(
            &mut canvas,
            (x, y),
            (x + r * a.cos(), y - r * a.sin()),
            image::Rgb([255, 60, 0]),
        );
    }
    canvas
}
