//! Table III: gradient magnitude maps from the mosaic vs from the grey image.
//!
//! For every Kodak image (RGB on [0, 1]): the mosaic is the image sampled through an RGGB filter,
//! the reference is its BT.601 grey image; both get the central-difference magnitude
//! ([`gradient_magnitude`], on [0, 1]) and we score the mosaic map against the grey map with
//! MSSIM (data range 1), PSNR (data range 1) and GMSD (paper eq. 23, `c = 0.0026`). The real raw
//! frames are scored the same way against a minimal forward ISP (white balance, bilinear demosaic,
//! grey; linear, no gamma on either side).
//!
//! ```no_run
//! use mosaicd::eval::{common::EvalOptions, gradients};
//! let r = gradients::run(&EvalOptions { limit: Some(2), raw_limit: Some(1), out: "out/eval".into(), progress: false }).unwrap();
//! println!("{}", r.to_text());
//! ```

use super::common::*;
use super::plot::{box_plot, Distribution};
use crate::image::Image;
use crate::metrics::gmsd::{gmsd, PAPER_C};
use crate::metrics::psnr::psnr;
use crate::metrics::ssim::{mssim, SsimOptions};
use crate::raw::Cfa;

/// The paper's Table III, Kodak row: MSSIM, PSNR (dB), GMSD.
pub const PAPER_KODAK: [f64; 3] = [0.975, 38.276, 0.069];
/// Data range of the magnitude maps compared (magnitudes on [0, 1]).
pub const MAGNITUDE_RANGE: f64 = 1.0;

/// MSSIM, PSNR and GMSD of a test gradient map against a reference map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapScores {
    /// Mean SSIM (data range 1).
    pub mssim: f64,
    /// PSNR in dB (data range 1).
    pub psnr: f64,
    /// GMSD with the paper's `c`.
    pub gmsd: f64,
}

/// Scores `test` against `reference` (two gradient magnitude maps on [0, 1]).
pub fn score_maps(reference: &Image<f32>, test: &Image<f32>) -> Result<MapScores> {
    let spec = SsimOptions::with_data_range(MAGNITUDE_RANGE).build()?;
    Ok(MapScores {
        mssim: mssim(reference.view(), test.view(), &spec)?,
        psnr: psnr(reference.view(), test.view(), MAGNITUDE_RANGE)?,
        gmsd: gmsd(reference.view(), test.view(), PAPER_C)?,
    })
}

/// Scores of the mosaic gradient against the grey gradient of one RGB image.
pub fn kodak_scores(rgb: &Image<[f32; 3]>) -> Result<MapScores> {
    let mosaic = mosaic_from_rgb(rgb.view(), Cfa::Rggb);
    let grey = grey_from_rgb(rgb.view());
    score_maps(
        &gradient_magnitude(grey.view()),
        &gradient_magnitude(mosaic.view()),
    )
}

/// Bilinear demosaicing by normalised convolution with the 3x3 tent `[1 2 1]ᵀ[1 2 1]/4` on each
/// colour's samples (equal to the classic bilinear kernels inside the image; reflect-101 borders).
/// *Adapter*: equals `isp::demosaic` bilinear away from the border.
pub fn bilinear_demosaic(mosaic: &Image<f32>, cfa: Cfa) -> Image<[f32; 3]> {
    use crate::raw::cfa::Colour;
    let (w, h) = mosaic.dimensions();
    let refl = |i: isize, n: usize| -> usize {
        if i < 0 {
            (-i) as usize
        } else if i as usize >= n {
            2 * n - 2 - i as usize
        } else {
            i as usize
        }
    };
    const TENT: [f32; 3] = [1.0, 2.0, 1.0];
    Image::from_fn(w, h, |x, y| {
        let mut num = [0.0f32; 3];
        let mut den = [0.0f32; 3];
        for dy in -1isize..=1 {
            for dx in -1isize..=1 {
                let sx = refl(x as isize + dx, w);
                let sy = refl(y as isize + dy, h);
                let c = match cfa.colour_at(sx, sy) {
                    Colour::Red => 0,
                    Colour::Green => 1,
                    Colour::Blue => 2,
                };
                let wgt = TENT[(dx + 1) as usize] * TENT[(dy + 1) as usize];
                num[c] += wgt * mosaic.get(sx, sy);
                den[c] += wgt;
            }
        }
        let own = match cfa.colour_at(x, y) {
            Colour::Red => 0,
            Colour::Green => 1,
            Colour::Blue => 2,
        };
        let mut out = [num[0] / den[0], num[1] / den[1], num[2] / den[2]];
        out[own] = mosaic.get(x, y);
        out
    })
}

/// Scores for a real raw frame: mosaic gradient (white-balanced per pixel) vs the grey gradient of
/// the minimal forward ISP (white balance, bilinear demosaic, grey), both linear and clamped to [0, 1].
pub fn raw_scores(input: &RawInput) -> Result<MapScores> {
    use crate::raw::cfa::Colour;
    let m = load_raw(input)?;
    let wb = Image::from_fn(m.width(), m.height(), |x, y| {
        let g = match input.cfa.colour_at(x, y) {
            Colour::Red => input.wb[0],
            Colour::Green => input.wb[1],
            Colour::Blue => input.wb[2],
        };
        (m.get(x, y) * g).clamp(0.0, 1.0)
    });
    let rgb = bilinear_demosaic(&wb, input.cfa);
    let grey = grey_from_rgb(rgb.view());
    score_maps(&gradient_magnitude(grey.view()), &gradient_magnitude(wb.view()))
}

/// Runs Table III on Kodak (first `limit` images) and the real raw frames.
pub fn run(opts: &EvalOptions) -> Result<Report> {
    let names = kodak_names(opts.limit)?;
    let prog = Progress::new("gradients: kodak", names.len(), opts.progress);
    let mut rows = Vec::new();
    for (i, n) in names.iter().enumerate() {
        prog.step(i, n);
        rows.push((n.clone(), kodak_scores(&load_kodak(n)?)?));
    }
    prog.done();
    let raws = raw_inputs(opts.raw_limit);
    let prog = Progress::new("gradients: raw", raws.len(), opts.progress);
    let mut raw_rows = Vec::new();
    for (i, r) in raws.iter().enumerate() {
        prog.step(i, r.name);
        raw_rows.push((r.name.to_string(), raw_scores(r)?));
    }
    prog.done();

    let mean = |v: &[(String, MapScores)], f: fn(&MapScores) -> f64| {
        finite_mean(&v.iter().map(|r| f(&r.1)).collect::<Vec<_>>())
    };
    let mut t = Table::new(
        "Table III: gradient magnitude of the mosaic vs of the grey image (mean over images)",
        &[
            "data",
            "images",
            "MSSIM",
            "paper",
            "PSNR (dB)",
            "paper",
            "GMSD",
            "paper",
        ],
    );
    let kodak = [
        mean(&rows, |s| s.mssim),
        mean(&rows, |s| s.psnr),
        mean(&rows, |s| s.gmsd),
    ];
    t.row(vec![
        "Kodak".into(),
        rows.len().to_string(),
        fmt(kodak[0].0, 3),
        fmt(PAPER_KODAK[0], 3),
        fmt(kodak[1].0, 3),
        fmt(PAPER_KODAK[1], 3),
        fmt(kodak[2].0, 3),
        fmt(PAPER_KODAK[2], 3),
    ]);
    if !raw_rows.is_empty() {
        let raw = [
            mean(&raw_rows, |s| s.mssim),
            mean(&raw_rows, |s| s.psnr),
            mean(&raw_rows, |s| s.gmsd),
        ];
        t.row(vec![
            "real raw (vs forward ISP)".into(),
            raw_rows.len().to_string(),
            fmt(raw[0].0, 3),
            "—".into(),
            fmt(raw[1].0, 3),
            "—".into(),
            fmt(raw[2].0, 3),
            "—".into(),
        ]);
    }
    let mut per = Table::new("Per image", &["image", "MSSIM", "PSNR (dB)", "GMSD"]);
    for (n, s) in rows.iter().chain(&raw_rows) {
        per.row(vec![n.clone(), fmt(s.mssim, 4), fmt(s.psnr, 3), fmt(s.gmsd, 4)]);
    }
    let plot = opts.out.join("table3_gradients.png");
    box_plot(
        "Mosaic vs grey gradient magnitude: GMSD per Kodak image",
        "GMSD",
        &[Distribution::new(
            "Kodak",
            rows.iter().map(|r| r.1.gmsd).collect(),
        )],
        &plot,
    )?;
    Ok(Report {
        name: "gradients".into(),
        heading: "Table III — gradients from the mosaic vs from the grey image".into(),
        tables: vec![t, per],
        plots: vec![plot],
        notes: vec![
            "Kodak mosaics are the RGB images sampled through RGGB; the reference is BT.601 grey. Magnitudes are ½·√(gx²+gy²) of the [-1, 0, 1] operator (reflect-101 borders) on [0, 1] images, so MSSIM/PSNR use data range 1 and GMSD the paper's c = 0.0026.".into(),
            "The paper does not state its magnitude scaling or border handling; both change PSNR by a constant and GMSD slightly.".into(),
            "Real raw rows: black/white-normalised mosaic with per-pixel white balance vs grey of a minimal forward ISP (same white balance, bilinear demosaic), both linear (no colour matrix, no gamma: a tone curve would be applied to both sides alike). The paper has no number for this row.".into(),
        ],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_scene_scores_perfectly() {
        // A grey (R = G = B) image: the mosaic equals the grey image, so the maps are identical.
        let rgb = Image::from_fn(32, 24, |x, y| {
            let v = ((x * 7 + y * 3) % 10) as f32 / 10.0;
            [v, v, v]
        });
        let s = kodak_scores(&rgb).unwrap();
        assert!((s.mssim - 1.0).abs() < 1e-12);
        assert!(s.psnr.is_infinite());
        assert_eq!(s.gmsd, 0.0);
    }

    #[test]
    fn bilinear_demosaic_keeps_samples_and_flat() {
        let rgb = Image::filled(8, 6, [0.2f32, 0.5, 0.9]);
        let m = mosaic_from_rgb(rgb.view(), Cfa::Grbg);
        let d = bilinear_demosaic(&m, Cfa::Grbg);
        for p in d.as_slice() {
            assert!((p[0] - 0.2).abs() < 1e-6 && (p[1] - 0.5).abs() < 1e-6 && (p[2] - 0.9).abs() < 1e-6);
        }
    }
}
