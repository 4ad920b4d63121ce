//! `mosaicd sift FILE`: SIFT keypoints of one frame, as JSON and as a picture.
//!
//! ```text
//! mosaicd sift DSC_1339_768x512_rggb.raw --width 768 --height 512 --bit-depth 14 --cfa RGGB \
//!     --black 600 --white 15520 --json out/sift.json --picture out/sift.png
//! mosaicd sift kodim09.png --as grey --json out/kodim09.json      # OpenCV-equivalent grey SIFT
//! mosaicd sift a.raw --match b.raw --width 768 --height 512 --bit-depth 14 --cfa RGGB \
//!     --match-json out/ab.json --match-picture out/ab.png     # register two raw frames
//! ```
//!
//! With `--match OTHER` the second input (same format flags) goes through the same SIFT, the
//! descriptors are matched (nearest neighbour, Lowe's ratio 0.8, mutual check) and an affine map
//! from the first frame to the second is fitted by RANSAC (3-point samples, 2000 draws from a fixed
//! seed, inliers within `--match-threshold` pixels) and refitted on its inliers by least squares
//! (the paper's `Ĥ = A†B`). Fewer than three consistent matches give no transform (reported, not an
//! error).

use std::path::PathBuf;

use anyhow::Context;
use serde::Serialize;

use super::input::InputArgs;
use mosaicd::features::sift::matching::{apply, match_descriptors, ransac_transform, LOWE_RATIO};
use mosaicd::features::sift::{
    detect_and_compute, normalised_mosaic_from_frame, Domain, Keypoint, SiftFeatures, SiftOptions, SiftSpec,
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
    /// Also run SIFT on this second input (same format flags), match the two and fit an affine map
    /// from the first to the second.
    #[arg(long = "match", value_name = "OTHER")]
    pub match_with: Option<PathBuf>,
    /// RANSAC inlier distance for --match, pixels.
    #[arg(long, default_value_t = 3.0, requires = "match_with")]
    pub match_threshold: f64,
    /// Write the matches and the transform as JSON here (with --match).
    #[arg(long, requires = "match_with")]
    pub match_json: Option<PathBuf>,
    /// Write the two frames side by side with the matches drawn (inliers green, others red) here
    /// (with --match).
    #[arg(long, requires = "match_with")]
    pub match_picture: Option<PathBuf>,
}

/// RANSAC draws for --match.
const RANSAC_ITERATIONS: usize = 2000;
/// RANSAC seed for --match (results are reproducible).
const RANSAC_SEED: u64 = 0;

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
    let (img, domain) = sift_image(&args, &args.input)?;
    let spec = sift_spec(&args, domain)?;
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
    if let Some(other) = &args.match_with {
        let mut input = args.input.clone();
        input.input = other.clone();
        let (img2, _) = sift_image(&args, &input)?;
        let f2 = pool.install(|| detect_and_compute(img2.view(), &spec))?;
        match_two(&args, (&img, &f), (&img2, &f2))?;
    }
    write_outputs(&args, &img, domain, &f, seconds)
}

/// The image SIFT runs on for `input` (per `args.domain`) and its domain.
fn sift_image(args: &SiftArgs, input: &InputArgs) -> anyhow::Result<(Image<f32>, Domain)> {
    let loaded = input.load()?;
    let (img, domain) = match args.domain {
        SiftDomainArg::Mosaic => (normalised_mosaic_from_frame(&loaded.frame), Domain::Mosaic),
        SiftDomainArg::Grey => {
            let rgb = loaded
                .rgb
                .as_ref()
                .context("--as grey needs an RGB input (PNG/JPEG/BMP); use --as mosaic for raw data")?;
            let g = rgb.map(|p| mosaicd::isp::grey_f32(p.map(f32::from)).round() / 255.0);
            (g, Domain::Grey)
        }
    };
    Ok((img, domain))
}

/// The SIFT spec of `args` for `domain`.
fn sift_spec(args: &SiftArgs, domain: Domain) -> anyhow::Result<SiftSpec> {
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
    Ok(opts.build()?)
}

fn write_outputs(
    args: &SiftArgs,
    img: &Image<f32>,
    domain: Domain,
    f: &SiftFeatures,
    seconds: f64,
) -> anyhow::Result<()> {
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
        picture(img, f)
            .save(p)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    if args.json.is_none() && args.picture.is_none() && args.match_with.is_none() {
        for k in &f.keypoints {
            println!(
                "{:.2} {:.2} {:.2} {:.1} {:.4}",
                k.x, k.y, k.size, k.angle, k.response
            );
        }
    }
    Ok(())
}

#[derive(Serialize)]
struct MatchOut {
    /// Index of the keypoint in the first input's list.
    a: usize,
    /// Index in the second input's list.
    b: usize,
    a_xy: [f32; 2],
    b_xy: [f32; 2],
    distance: f32,
    inlier: bool,
}

#[derive(Serialize)]
struct MatchReport {
    a: String,
    b: String,
    keypoints: [usize; 2],
    matches: Vec<MatchOut>,
    inliers: usize,
    threshold_px: f64,
    /// `[x' y'] = [x y 1] M` with `M` 3x2 (the paper's row convention); null without a fit.
    affine: Option<[[f64; 2]; 3]>,
    /// RMS distance of the inliers under the refitted map, pixels.
    inlier_rms_px: Option<f64>,
}

/// Match the two inputs' features, fit the affine map, report, and write what was asked for.
fn match_two(
    args: &SiftArgs,
    a: (&Image<f32>, &SiftFeatures),
    b: (&Image<f32>, &SiftFeatures),
) -> anyhow::Result<()> {
    let (fa, fb) = (a.1, b.1);
    let ms = match_descriptors(&fa.descriptors, &fb.descriptors, LOWE_RATIO, true);
    let xy = |k: &Keypoint| (k.x as f64, k.y as f64);
    let src: Vec<(f64, f64)> = ms.iter().map(|m| xy(&fa.keypoints[m.query])).collect();
    let dst: Vec<(f64, f64)> = ms.iter().map(|m| xy(&fb.keypoints[m.train])).collect();
    let fit = ransac_transform(&src, &dst, args.match_threshold, RANSAC_ITERATIONS, RANSAC_SEED);
    let mut inlier = vec![false; ms.len()];
    for &i in fit.iter().flat_map(|r| &r.inliers) {
        inlier[i] = true;
    }
    let rms = fit.as_ref().filter(|r| !r.inliers.is_empty()).map(|r| {
        let s: f64 = r
            .inliers
            .iter()
            .map(|&i| {
                let (u, v) = apply(&r.transform, src[i]);
                (u - dst[i].0).powi(2) + (v - dst[i].1).powi(2)
            })
            .sum();
        (s / r.inliers.len() as f64).sqrt()
    });
    let report = MatchReport {
        a: args.input.input.display().to_string(),
        b: args
            .match_with
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_default(),
        keypoints: [fa.keypoints.len(), fb.keypoints.len()],
        matches: ms
            .iter()
            .zip(&inlier)
            .map(|(m, &ok)| MatchOut {
                a: m.query,
                b: m.train,
                a_xy: [fa.keypoints[m.query].x, fa.keypoints[m.query].y],
                b_xy: [fb.keypoints[m.train].x, fb.keypoints[m.train].y],
                distance: m.distance,
                inlier: ok,
            })
            .collect(),
        inliers: fit.as_ref().map_or(0, |r| r.inliers.len()),
        threshold_px: args.match_threshold,
        affine: fit.as_ref().map(|r| {
            let t = &r.transform;
            [[t[0][0], t[0][1]], [t[1][0], t[1][1]], [t[2][0], t[2][1]]]
        }),
        inlier_rms_px: rms,
    };
    match &report.affine {
        Some(m) => eprintln!(
            "match: {} / {} keypoints, {} matches, {} inliers (within {} px, RMS {:.2} px); \
             x' = {:.4} x + {:.4} y + {:.2}, y' = {:.4} x + {:.4} y + {:.2}",
            report.keypoints[0],
            report.keypoints[1],
            report.matches.len(),
            report.inliers,
            args.match_threshold,
            rms.unwrap_or(f64::NAN),
            m[0][0],
            m[1][0],
            m[2][0],
            m[0][1],
            m[1][1],
            m[2][1]
        ),
        None => eprintln!(
            "match: {} / {} keypoints, {} matches: no transform (fewer than three consistent matches)",
            report.keypoints[0],
            report.keypoints[1],
            report.matches.len()
        ),
    }
    if let Some(p) = &args.match_json {
        write_parent(p)?;
        std::fs::write(p, serde_json::to_string(&report)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    if let Some(p) = &args.match_picture {
        write_parent(p)?;
        match_picture(a, b, &report)
            .save(p)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

/// The two frames side by side (square-root tone), keypoints as crosses, matches as lines: green
/// for the transform's inliers, red for the rest.
fn match_picture(
    a: (&Image<f32>, &SiftFeatures),
    b: (&Image<f32>, &SiftFeatures),
    r: &MatchReport,
) -> image::RgbImage {
    let (ia, ib) = (a.0, b.0);
    let w = ia.width() + ib.width();
    let h = ia.height().max(ib.height());
    let mut canvas = image::RgbImage::new(w as u32, h as u32);
    paint_sqrt(&mut canvas, ia, 0);
    paint_sqrt(&mut canvas, ib, ia.width());
    mosaicd::eval::draw_keypoints(&mut canvas, a.1, 0);
    mosaicd::eval::draw_keypoints(&mut canvas, b.1, ia.width());
    for m in &r.matches {
        let c = if m.inlier {
            image::Rgb([0, 220, 0])
        } else {
            image::Rgb([255, 0, 0])
        };
        mosaicd::eval::draw_line(
            &mut canvas,
            (m.a_xy[0] as f64, m.a_xy[1] as f64),
            (m.b_xy[0] as f64 + ia.width() as f64, m.b_xy[1] as f64),
            c,
        );
    }
    canvas
}

fn write_parent(p: &std::path::Path) -> anyhow::Result<()> {
    if let Some(d) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d)?;
    }
    Ok(())
}

/// Paint `img` (values on [0, 1]) into `canvas` at column `ox` with a square-root tone curve.
fn paint_sqrt(canvas: &mut image::RgbImage, img: &Image<f32>, ox: usize) {
    for y in 0..img.height() {
        for x in 0..img.width() {
            let v = (img.get(x, y).clamp(0.0, 1.0).sqrt() * 255.0) as u8;
            canvas.put_pixel((x + ox) as u32, y as u32, image::Rgb([v, v, v]));
        }
    }
}

/// The image on [0, 1] shown with a square-root tone curve, keypoints drawn on top.
fn picture(img: &Image<f32>, f: &SiftFeatures) -> image::RgbImage {
    let mut canvas = image::RgbImage::new(img.width() as u32, img.height() as u32);
    paint_sqrt(&mut canvas, img, 0);
    let c = image::Rgb([255, 220, 0]);
    for k in &f.keypoints {
        let r = (k.size as f64 * 0.5).max(1.5);
        let (x, y) = (k.x as f64, k.y as f64);
        let n = ((r * 6.3).ceil() as usize).max(8);
        for i in 0..n {
            let a0 = i as f64 / n as f64 * std::f64::consts::TAU;
            let a1 = (i + 1) as f64 / n as f64 * std::f64::consts::TAU;
            mosaicd::eval::draw_line(
                &mut canvas,
                (x + r * a0.cos(), y + r * a0.sin()),
                (x + r * a1.cos(), y + r * a1.sin()),
                c,
            );
        }
        // OpenCV angles are counter-clockwise with y up.
        let a = (k.angle as f64).to_radians();
        mosaicd::eval::draw_line(
            &mut canvas,
            (x, y),
            (x + r * a.cos(), y - r * a.sin()),
            image::Rgb([255, 60, 0]),
        );
    }
    canvas
}
