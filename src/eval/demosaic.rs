//! Table IV: each demosaicing method vs the true colour image on Kodak — MSSIM, PSNR, GMSD.
//!
//! Every Kodak image (RGB on [0, 1]) is sampled through RGGB, demosaiced with each
//! [`DemosaicMethod`], clamped to [0, 1] (as quantising to 8 bits would) and compared with the
//! original: MSSIM is the mean of the per-channel MSSIMs (data range 1), PSNR is over all three
//! channels (data range 1, so identical to the 8-bit dB), GMSD is Xue et al. 2014's index on
//! BT.601 luminance ×255 ([`gmsd_xue2014`]). A border of [`BORDER`] pixels is excluded, as is usual
//! for demosaicing benchmarks (every method guesses there).
//!
//! ```no_run
//! use mosaicd::eval::{run_demosaic, EvalOptions};
//! let r = run_demosaic(&EvalOptions { limit: Some(2), raw_limit: Some(1), out: "out/eval".into(), progress: false }).unwrap();
//! println!("{}", r.to_text());
//! ```

use super::common::*;
use super::plot::{box_plot, Distribution};
use crate::image::Image;
use crate::isp::demosaic::rgb_from_mosaic;
use crate::isp::DemosaicMethod;
use crate::metrics::gmsd::gmsd_xue2014;
use crate::metrics::psnr::psnr;
use crate::metrics::ssim::{mssim, SsimOptions};
use crate::raw::Cfa;

/// Pixels excluded at each border before scoring.
pub(crate) const BORDER: usize = 8;

/// MSSIM, PSNR and GMSD of one demosaiced image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ColourScores {
    /// Mean of per-channel MSSIM.
    pub mssim: f64,
    /// PSNR over all channels, dB.
    pub psnr: f64,
    /// Xue et al. 2014 GMSD on luminance.
    pub gmsd: f64,
}

fn inner<P: Copy>(img: &Image<P>) -> Image<P> {
    img.view()
        .crop(
            BORDER,
            BORDER,
            img.width() - 2 * BORDER,
            img.height() - 2 * BORDER,
        )
        .expect("images are larger than the border")
        .to_image()
}

/// Scores a colour image against the truth (both RGB on [0, 1]), borders excluded.
pub(crate) fn score_colour(truth: &Image<[f32; 3]>, test: &Image<[f32; 3]>) -> Result<ColourScores> {
    let (t, d) = (inner(truth), inner(test));
    let spec = SsimOptions::with_data_range(1.0).build()?;
    let luma = |i: &Image<[f32; 3]>| grey_from_rgb(i.view()).map(|v| v * 255.0);
    Ok(ColourScores {
        mssim: mssim(t.view(), d.view(), &spec)?,
        psnr: psnr(t.view(), d.view(), 1.0)?,
        gmsd: gmsd_xue2014(luma(&t).view(), luma(&d).view())?,
    })
}

/// Scores of every method (in [`DemosaicMethod::all`] order) on one RGB image.
pub(crate) fn image_scores(rgb: &Image<[f32; 3]>) -> Result<Vec<ColourScores>> {
    let cfa = Cfa::Rggb;
    let mosaic = mosaic_from_rgb(rgb.view(), cfa);
    DemosaicMethod::all()
        .iter()
        .map(|&m| {
            let d = rgb_from_mosaic(mosaic.view(), cfa, m)?.map(|p| p.map(|c| c.clamp(0.0, 1.0)));
            score_colour(rgb, &d)
        })
        .collect()
}

/// Runs Table IV on the first `limit` Kodak images.
pub fn run(opts: &EvalOptions) -> Result<Report> {
    let names = kodak_names(opts.limit)?;
    let prog = Progress::new("demosaic", names.len(), opts.progress);
    let mut per = Vec::new();
    for (i, n) in names.iter().enumerate() {
        prog.step(i, n);
        per.push(image_scores(&load_kodak(n)?)?);
    }
    prog.done();
    let mut t = Table::new(
        "Table IV: demosaicing vs true colour (Kodak, RGGB, mean over images)",
        &["method", "MSSIM", "PSNR (dB)", "GMSD (Xue 2014)", "paper"],
    );
    let mut dists = Vec::new();
    for (k, m) in DemosaicMethod::all().iter().enumerate() {
        let col =
            |f: fn(&ColourScores) -> f64| finite_mean(&per.iter().map(|s| f(&s[k])).collect::<Vec<_>>()).0;
        t.row(vec![
            m.name().to_string(),
            fmt(col(|s| s.mssim), 4),
            fmt(col(|s| s.psnr), 3),
            fmt(col(|s| s.gmsd), 4),
            "see paper".into(),
        ]);
        dists.push(Distribution::new(
            m.name(),
            per.iter().map(|s| s[k].psnr).collect(),
        ));
    }
    let plot = opts.out.join("table4_demosaic_psnr.png");
    box_plot(
        "Demosaicing vs true colour: PSNR per Kodak image",
        "PSNR (dB)",
        &dists,
        &plot,
    )?;
    Ok(Report {
        name: "demosaic".into(),
        heading: "Table IV — demosaicing methods vs true colour".into(),
        tables: vec![t],
        plots: vec![plot],
        notes: vec![
            format!("Kodak sampled through RGGB, demosaiced by isp::demosaic, clamped to [0, 1]; {BORDER}-pixel border excluded. MSSIM = mean of per-channel MSSIM (σ = 1.5, data range 1); PSNR over all channels; GMSD = Xue et al. 2014 on BT.601 luminance on 0–255."),
            "Paper numbers for Table IV were not available to this run ('see paper'). The paper does not say whether borders are excluded.".into(),
        ],
    })
}
