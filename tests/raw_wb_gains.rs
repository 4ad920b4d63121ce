//! Does white balance improve the parity of mosaic gradients with the gradients of a conventional
//! ISP's grey image? (issue 2, item 2.)
//!
//! For each real raw frame: the reference is the frame normalised (black/white), demosaiced
//! bilinearly (`isp::demosaic`), white-balanced with the best gains we know for it (the sensor's
//! tuning when we have it, otherwise grey world), clamped to [0, 1] and turned into BT.601 grey
//! (`isp::grey`); its gradient is the [-1, 0, 1] central difference in x and y
//! (`features::gradient`), magnitude `sqrt(gx² + gy²)`. The mosaic gradient is the
//! same operator applied directly to the normalised mosaic (taps at x±1 and y±1 share a colour),
//! once without gains and once with each gains mode. Scores over the interior (2-pixel border
//! left out): PSNR of the magnitude maps (peak 1) and GMSD (std of the gradient-magnitude
//! similarity map, c = 170/255², Xue et al. 2014; lower is better), and the mean unsigned
//! orientation difference weighted by the reference magnitude (what HOG bins care about).
//!
//! `cargo test --release --test raw_wb_gains -- --ignored --nocapture` prints the table that
//! docs/raw.md reports; the cheap test checks one small frame on every run.

use mosaicd::data::require;
use mosaicd::features::gradient::{gradients_from_image, GradientSpec};
use mosaicd::image::Image;
use mosaicd::isp::grey_from_rgb_f32;
use mosaicd::isp::rgb_from_mosaic_bilinear;
use mosaicd::raw::{f32_from_raw, grey_world_gains, Compression, Gains, NormaliseOptions};
use mosaicd::raw::{load_input, Cfa, InputOptions, RawFrame};

/// GMSD stability constant for values in [0, 1] (170 for [0, 255] in Xue et al.).
const GMSD_C: f64 = 170.0 / (255.0 * 255.0);
/// Border left out of the scores (the gradient and the demosaic both touch 1 pixel).
const BORDER: usize = 2;

fn normalised(frame: &RawFrame, gains: Gains) -> Image<f32> {
    let spec = NormaliseOptions {
        gains,
        compression: Compression::None,
    }
    .build()
    .unwrap();
    f32_from_raw(frame, &spec).unwrap()
}

fn grey_reference(frame: &RawFrame, gains: [f32; 3]) -> Image<f32> {
    let lin = normalised(frame, Gains::None);
    let rgb = rgb_from_mosaic_bilinear(lin.view(), frame.cfa()).unwrap();
    let balanced = rgb.map(|p| {
        [
            (p[0] * gains[0]).min(1.0),
            (p[1] * gains[1]).min(1.0),
            (p[2] * gains[2]).min(1.0),
        ]
    });
    grey_from_rgb_f32(&balanced.view())
}

/// `features::gradient` central difference [-1, 0, 1] (gx, gy) per pixel.
fn gradient(img: &Image<f32>) -> Image<[f32; 2]> {
    let g = gradients_from_image(&img.view(), &GradientSpec::default()).unwrap();
    let (w, h) = img.dimensions();
    Image::from_fn(w, h, |x, y| [g.gx.get(x, y), g.gy.get(x, y)])
}

/// Unsigned orientation difference in degrees (0..=90) between two gradient vectors.
fn orientation_diff(a: [f32; 2], b: [f32; 2]) -> f64 {
    let ta = (a[1] as f64).atan2(a[0] as f64).to_degrees().rem_euclid(180.0);
    let tb = (b[1] as f64).atan2(b[0] as f64).to_degrees().rem_euclid(180.0);
    let d = (ta - tb).abs();
    d.min(180.0 - d)
}

/// Parity scores of a mosaic gradient magnitude against the reference one.
#[derive(Debug, Clone, Copy)]
struct Parity {
    psnr: f64,
    gmsd: f64,
    gmsm: f64,
    /// Mean unsigned orientation difference in degrees, weighted by the reference magnitude.
    orient: f64,
}

fn parity(mosaic: &Image<[f32; 2]>, reference: &Image<[f32; 2]>) -> Parity {
    let (w, h) = reference.dimensions();
    let mag = |g: [f32; 2]| ((g[0] * g[0] + g[1] * g[1]) as f64).sqrt();
    let mut se = 0.0;
    let (mut osum, mut wsum) = (0.0, 0.0);
    let mut gms = Vec::with_capacity(w * h);
    for y in BORDER..h - BORDER {
        for x in BORDER..w - BORDER {
            let (ga, gb) = (mosaic.get(x, y), reference.get(x, y));
            let (a, b) = (mag(ga), mag(gb));
            osum += b * orientation_diff(ga, gb);
            wsum += b;
            se += (a - b) * (a - b);
            gms.push((2.0 * a * b + GMSD_C) / (a * a + b * b + GMSD_C));
        }
    }
    let n = gms.len() as f64;
    let mse = se / n;
    let gmsm = gms.iter().sum::<f64>() / n;
    let gmsd = (gms.iter().map(|g| (g - gmsm) * (g - gmsm)).sum::<f64>() / n).sqrt();
    Parity {
        psnr: 10.0 * (1.0 / mse).log10(),
        gmsd,
        gmsm,
        orient: if wsum > 0.0 { osum / wsum } else { 0.0 },
    }
}

/// One real frame with the white balance we trust most for it.
struct Case {
    name: &'static str,
    frame: RawFrame,
    /// Gains from the sensor's own tuning file, when there is one.
    tuned: Option<[f32; 3]>,
}

fn load(rel: &str, opts: InputOptions) -> RawFrame {
    load_input(&require(rel), &opts).unwrap().frame
}

fn headerless(w: usize, h: usize, bits: u8, cfa: Cfa, black: u16, white: Option<u16>) -> InputOptions {
    InputOptions {
        width: Some(w),
        height: Some(h),
        bit_depth: Some(bits),
        cfa: Some(cfa),
        black: Some([black; 4]),
        white,
        ..InputOptions::default()
    }
}

fn halide() -> Case {
    Case {
        name: "halide bayer_small.png (GRBG 10-bit in 11, 25/1023)",
        frame: load(
            "raw/halide/bayer_small.png",
            InputOptions {
                cfa: Some(Cfa::Grbg),
                bit_depth: Some(11),
                black: Some([25; 4]),
                white: Some(1023),
                ..InputOptions::default()
            },
        ),
        tuned: None,
    }
}

fn all_cases() -> Vec<Case> {
    let mut v = vec![Case {
        name: "Nikon rose (RGGB 14-bit, 600/15520)",
        frame: load(
            "raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw",
            headerless(768, 512, 14, Cfa::Rggb, 600, Some(15520)),
        ),
        tuned: None,
    }];
    // Infinite-ISP tuning files: white_balance r_gain 1.44921875, b_gain 3.2421875 (all scenes).
    for name in ["Indoor1", "Outdoor1", "Outdoor2", "Outdoor3", "Outdoor4"] {
        v.push(Case {
            name: Box::leak(format!("Infinite-ISP {name} (GRBG 8-bit, 12/255)").into_boxed_str()),
            frame: load(
                &format!("raw/infinite_isp_8bit/{name}_2592x1536_8bit_GRBG.raw"),
                headerless(2592, 1536, 8, Cfa::Grbg, 12, None),
            ),
            tuned: Some([1.449_218_8, 1.0, 3.242_187_5]),
        });
    }
    // openisp config.csv: r_gain 1.5, gr_gain 1, gb_gain 1.1 (the last is the blue gain).
    v.push(Case {
        name: "openisp test.RAW (RGGB 10-bit, 0/1023)",
        frame: load(
            "raw/openisp/test.RAW",
            headerless(1920, 1080, 10, Cfa::Rggb, 0, None),
        ),
        tuned: Some([1.5, 1.0, 1.1]),
    });
    v.push(halide());
    // Kodak DC50 KDC through our RADC decoder: the file has no white balance (LibRaw uses 1, 1, 1).
    v.push(Case {
        name: "Kodak DC50 KDC (GRBG 14-bit linearised, 0/16383)",
        frame: load("raw/rawpy_kodak_dc50/RAW_KODAK_DC50.KDC", InputOptions::default()),
        tuned: None,
    });
    v
}

/// Scores of the mosaic gradient without gains, with grey-world gains and (when known) with the
/// tuned gains, against the reference built with the trusted gains.
struct Row {
    reference_gains: [f32; 3],
    none: Parity,
    grey_world: Parity,
    tuned: Option<Parity>,
}

fn measure(case: &Case) -> Row {
    let gw = grey_world_gains(&case.frame);
    let reference_gains = case.tuned.unwrap_or(gw);
    let reference = gradient(&grey_reference(&case.frame, reference_gains));
    let score = |g: Gains| parity(&gradient(&normalised(&case.frame, g)), &reference);
    Row {
        reference_gains,
        none: score(Gains::None),
        grey_world: score(Gains::GreyWorld),
        tuned: case.tuned.map(|t| score(Gains::Fixed(t))),
    }
}

fn fmt(p: &Parity) -> String {
    format!("{:.2} dB, GMSD {:.4}, orient. {:.2}°", p.psnr, p.gmsd, p.orient)
}

/// Cheap check on the small Halide frame, run every time: the scores are sane, and on this frame
/// (as on average over all frames of the full measurement) the mosaic gradient without gains is
/// closer to the white-balanced ISP's grey gradient than with grey-world gains (the reason the
/// default gains mode is `None`).
#[test]
fn no_gains_gives_better_gradient_parity_on_halide_frame() {
    let case = halide();
    let row = measure(&case);
    for p in [row.none, row.grey_world] {
        assert!(p.psnr.is_finite() && p.psnr > 10.0, "{p:?}");
        assert!(
            (0.0..1.0).contains(&p.gmsd) && (0.0..=1.0).contains(&p.gmsm),
            "{p:?}"
        );
    }
    assert!(
        row.none.gmsd < row.grey_world.gmsd && row.none.psnr > row.grey_world.psnr,
        "none: {}\ngrey world: {}",
        fmt(&row.none),
        fmt(&row.grey_world)
    );
    // The default options are what the measurement chose.
    assert_eq!(NormaliseOptions::default().gains, Gains::None);
}

/// A mosaic of a grey linear ramp (R = G = B; bilinear demosaicing is exact on it) scores perfectly once
/// gains are 1: the measurement itself cannot invent a difference.
#[test]
fn measurement_is_exact_on_a_grey_scene() {
    let (w, h) = (32, 24);
    let px: Vec<u16> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            (100 + 30 * x + 50 * y) as u16
        })
        .collect();
    let f = RawFrame::from_u16(w, h, px, Cfa::Gbrg, 12, mosaicd::raw::Levels::uniform(0, 4095)).unwrap();
    let reference = gradient(&grey_reference(&f, [1.0; 3]));
    let p = parity(&gradient(&normalised(&f, Gains::None)), &reference);
    assert!(p.gmsd < 1e-6 && p.psnr > 100.0 && p.orient < 1e-3, "{p:?}");
}

/// The full measurement over every real raw frame (prints the table for docs/raw.md).
#[test]
#[ignore = "measurement over all real raw frames: ~1 min in release; run with --ignored --nocapture"]
fn wb_gains_measurement_table() {
    println!("| frame | reference gains (r, b) | no gains | grey-world gains | tuned gains |");
    println!("|---|---|---|---|---|");
    let (mut gw_wins, mut tuned_wins, mut tuned_n) = (0, 0, 0);
    let mut mean = [[0.0f64; 3]; 2];
    let cases = all_cases();
    for case in &cases {
        let row = measure(case);
        gw_wins += usize::from(row.grey_world.gmsd < row.none.gmsd);
        if let Some(t) = row.tuned {
            tuned_n += 1;
            tuned_wins += usize::from(t.gmsd < row.none.gmsd);
        }
        for (m, p) in mean.iter_mut().zip([row.none, row.grey_world]) {
            m[0] += p.psnr / cases.len() as f64;
            m[1] += p.gmsd / cases.len() as f64;
            m[2] += p.orient / cases.len() as f64;
        }
        println!(
            "| {} | {:.3}, {:.3} | {} | {} | {} |",
            case.name,
            row.reference_gains[0],
            row.reference_gains[2],
            fmt(&row.none),
            fmt(&row.grey_world),
            row.tuned.as_ref().map(fmt).unwrap_or_else(|| "–".into())
        );
    }
    println!(
        "| mean | | {:.2} dB, GMSD {:.4}, orient. {:.2}° | {:.2} dB, GMSD {:.4}, orient. {:.2}° | |",
        mean[0][0], mean[0][1], mean[0][2], mean[1][0], mean[1][1], mean[1][2]
    );
    println!(
        "grey-world gains lower GMSD on {gw_wins} of {} frames; tuned gains on {tuned_wins} of {tuned_n}",
        cases.len()
    );
}
