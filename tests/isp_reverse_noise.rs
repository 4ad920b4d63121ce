//! Reverse ISP on real data, shipped camera profiles, and the noise estimator on frames with
//! known injected noise.

use mosaicd::image::Image;
use mosaicd::isp::raw_from_linear_mosaic;
use mosaicd::isp::{add_noise, estimate_noise, raw_from_srgb, CameraProfile, NoiseLevel, ReverseIspOptions};
use mosaicd::isp::{linear_from_raw, NoiseEstimateOptions};
use mosaicd::raw::{Cfa, Levels};

fn load_rgb(rel: &str) -> Image<[u8; 3]> {
    let path = mosaicd::data::require(rel);
    let img = image::open(&path)
        .unwrap_or_else(|e| panic!("cannot decode {}: {e}", path.display()))
        .to_rgb8();
    let (w, h) = img.dimensions();
    let px: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    Image::from_vec(w as usize, h as usize, px).unwrap()
}

#[test]
fn shipped_default_profile_file_equals_builtin_default() {
    let p = CameraProfile::shipped("infinite_isp_indoor1").unwrap();
    assert_eq!(p, CameraProfile::default());
    let o = CameraProfile::shipped("infinite_isp_outdoor").unwrap();
    assert_eq!(o.cfa, Cfa::Grbg);
    assert_eq!((o.black_level, o.white_level, o.bit_depth), (50, 1023, 10));
    // 1921/1024, as in the Infinite-ISP outdoor tuning
    assert_eq!(o.ccm[0][0], 1921.0 / 1024.0);
}

#[test]
fn kodak_reverse_isp_statistics() {
    // kodim23 through the default profile at 12 bits, RGGB.
    let rgb = load_rgb("kodak/kodim23.png");
    let p = CameraProfile::default();
    let mut o = ReverseIspOptions::for_profile(&p);
    o.cfa = Cfa::Rggb;
    o.bit_depth = 12;
    let raw = raw_from_srgb(rgb.view(), &p, &o).unwrap();
    assert_eq!((raw.width(), raw.height()), (rgb.width(), rgb.height()));
    let (black, white) = (raw.levels().black[0], raw.levels().white);
    assert_eq!((black, white), (200, 4095));
    let v = raw.to_u16_vec();
    assert!(v.iter().all(|&x| x <= white));
    // an 8-bit sRGB image becomes a mostly in-range raw frame: few pixels clip at either end
    let clipped = v.iter().filter(|&&x| x == 0 || x == white).count();
    assert!(clipped * 100 < v.len(), "{clipped} of {} clipped", v.len());
    // green sites carry the luminance: their mean is above the red and blue means (gains > 1)
    let mut sums = [0f64; 3];
    let mut counts = [0usize; 3];
    for y in 0..raw.height() {
        for x in 0..raw.width() {
            let c = match raw.cfa().colour_at(x, y) {
                mosaicd::raw::Colour::Red => 0,
                mosaicd::raw::Colour::Green => 1,
                mosaicd::raw::Colour::Blue => 2,
            };
            sums[c] += raw.value(x, y) as f64 - black as f64;
            counts[c] += 1;
        }
    }
    let means: Vec<f64> = sums.iter().zip(counts).map(|(s, n)| s / n as f64).collect();
    assert!(means[1] > means[0] && means[1] > means[2], "{means:?}");
}

/// A smooth synthetic scene covering the signal range [lo, hi] about evenly (a ramp plus a gentle bump).
fn smooth_scene(w: usize, h: usize, lo: f32, hi: f32) -> Image<f32> {
    Image::from_fn(w, h, |x, y| {
        let u = x as f32 / w as f32;
        let v = y as f32 / h as f32;
        let t = u + 0.05 * (std::f32::consts::PI * v).sin();
        lo + (hi - lo) * (t / 1.05)
    })
}

fn estimate_after_injecting(level: NoiseLevel, seed: u64) -> (f64, f64) {
    let (w, h) = (1024, 1024);
    let mut lin = smooth_scene(w, h, 0.02, 0.9);
    add_noise(&mut lin, level.params(), seed).unwrap();
    // 16-bit with a black level so noise below black is kept (quantisation variance ~1e-11)
    let raw = raw_from_linear_mosaic(&lin, Cfa::Gbrg, 16, Levels::uniform(2048, 65535)).unwrap();
    let e = estimate_noise(&raw, &NoiseEstimateOptions::default()).unwrap();
    if std::env::var("DBG").is_ok() {
        let t = level.params();
        for (m, v, k) in &e.bins {
            eprintln!("{m:.4} {:.4} {k}", v / t.variance(*m));
        }
    }
    (e.params.a, e.params.b)
}

#[test]
fn estimator_recovers_each_preset() {
    // Tolerances: a within 6 %, b within 15 % of the truth or 5e-6 absolute, whichever is larger.
    for (i, level) in NoiseLevel::ALL.into_iter().enumerate() {
        let t = level.params();
        let (a, b) = estimate_after_injecting(level, 100 + i as u64);
        eprintln!(
            "{level:?}: a {a:.4e} (true {:.4e}), b {b:.4e} (true {:.4e})",
            t.a, t.b
        );
        assert!((a / t.a - 1.0).abs() < 0.06, "{level:?}: a = {a}, true {}", t.a);
        assert!(
            (b - t.b).abs() < (0.15 * t.b).max(5e-6),
            "{level:?}: b = {b}, true {}",
            t.b
        );
    }
}

#[test]
fn estimator_sees_almost_no_noise_on_a_clean_frame() {
    let lin = smooth_scene(256, 256, 0.05, 0.9);
    let raw = raw_from_linear_mosaic(&lin, Cfa::Rggb, 16, Levels::uniform(0, 65535)).unwrap();
    let e = estimate_noise(&raw, &NoiseEstimateOptions::default()).unwrap();
    let low = NoiseLevel::Low.params();
    assert!(
        e.params.a.abs() < 0.01 * low.a && e.params.b.abs() < 0.01 * low.b,
        "{:?}",
        e.params
    );
    // the linear view of the clean frame is the scene back (to 16-bit quantisation)
    let back = linear_from_raw(&raw);
    let err = back
        .as_slice()
        .iter()
        .zip(lin.as_slice())
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    assert!(err <= 0.5 / 65535.0 + 1e-7, "{err}");
}

/// The Nikon rose frame (768x512, 14-bit RGGB, black 600, white 15520), read as headerless LE u16.
fn nikon_rose() -> mosaicd::raw::RawFrame {
    let p = mosaicd::data::require("raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw");
    let bytes = std::fs::read(&p).unwrap();
    assert_eq!(bytes.len(), 768 * 512 * 2, "{}", p.display());
    let px: Vec<u16> = bytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect();
    mosaicd::raw::RawFrame::from_u16(768, 512, px, Cfa::Rggb, 14, Levels::uniform(600, 15520)).unwrap()
}

#[test]
fn estimator_on_a_real_frame_sees_injected_noise() {
    // The rose frame has its own (small) noise and texture; the estimator's answer on the frame
    // plus injected noise, minus its answer on the frame alone, must be the injected (a, b).
    // Tolerances (texture that survives the patch rejection inflates a): a within 15 %; b within
    // 15 % for Low and Medium, within 30 % for High, where sigma at black (0.058) exceeds the
    // headroom below the black level (600 / 14920 = 0.040), so dark patches clip and are dropped.
    let frame = nikon_rose();
    let opts = NoiseEstimateOptions::default();
    let base = estimate_noise(&frame, &opts).unwrap().params;
    eprintln!("nikon rose: a {:.3e} b {:.3e}", base.a, base.b);
    for (i, level) in NoiseLevel::ALL.into_iter().enumerate() {
        let noisy = mosaicd::isp::add_noise_to_raw(&frame, level.params(), 7 + i as u64).unwrap();
        let e = estimate_noise(&noisy, &opts).unwrap().params;
        let t = level.params();
        let (da, db) = (e.a - base.a, e.b - base.b);
        eprintln!(
            "{level:?}: added a {da:.3e} (true {:.3e}), b {db:.3e} (true {:.3e})",
            t.a, t.b
        );
        let b_tol = if level == NoiseLevel::High { 0.30 } else { 0.15 };
        assert!(
            (da / t.a - 1.0).abs() < 0.15,
            "{level:?}: added a {da}, true {}",
            t.a
        );
        assert!(
            (db / t.b - 1.0).abs() < b_tol,
            "{level:?}: added b {db}, true {}",
            t.b
        );
    }
}
