//! Parity of the mosaic operators with OpenCV (`cv2.filter2D` with `[-1, 0, 1]`, `cv2.Sobel` ksize 1
//! and 3, `cv2.magnitude`, `cv2.phase`, `cv2.cvtColor(RGB2GRAY)`) on the same mosaics: a seeded
//! synthetic 12-bit one, a crop of the real Nikon 14-bit raw, and Kodak kodim01 resampled to RGGB.
//! Fixtures come from `tests/oracle/gen_gradients.py` (`make oracle`).
//!
//! Tolerances: gx/gy are sums of integers well below 2^24, exact in f32 on both sides → **equal**.
//! Magnitude: relative 1e-6 (both `sqrt(x² + y²)` in f32; OpenCV's SIMD may differ by an ulp).
//! Phase: OpenCV's `phase` is a polynomial atan approximation, documented to ~0.3°; we allow 0.05°
//! (what it achieves in 4.x) — with wrap-around at 360°. Grey: **bit-exact**.
//! The fused kernel is compared with OpenCV's magnitude too: |ours − round(cv)| ≤ 1.

use std::path::PathBuf;

use mosaicd::features::gradient::{
    gradients_from_image, mag_bin_from_raw, AngleRange, Border, GradientSpec, MagBinOptions, MagBinSpec,
    Operator,
};
use mosaicd::image::Image;
use mosaicd::isp::grey_from_rgb_u8;
use mosaicd::npy::NpyArray;
use mosaicd::raw::{Cfa, Levels, RawFrame};

fn oracle_dir() -> PathBuf {
    match std::env::var_os("MOSAICD_ORACLE") {
        Some(p) => PathBuf::from(p),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/oracle"),
    }
    .join("gradients")
}

fn load(name: &str) -> NpyArray {
    let p = oracle_dir().join(format!("{name}.npy"));
    NpyArray::read(&p).unwrap_or_else(|e| {
        panic!(
            "oracle fixture {} missing or unreadable ({e}): run `make oracle` \
             (python3 tests/oracle/generate.py --out target/oracle) or set MOSAICD_ORACLE",
            p.display()
        )
    })
}

fn image(a: &NpyArray) -> Image<f32> {
    assert_eq!(a.shape.len(), 2, "expected a 2-D array, got {:?}", a.shape);
    Image::from_vec(a.shape[1], a.shape[0], a.data.iter().map(|&v| v as f32).collect()).unwrap()
}

const CASES: [&str; 3] = ["syn", "nikon", "kodak"];

#[test]
fn gx_gy_equal_opencv_filter2d_and_sobel() {
    for case in CASES {
        let input = load(&format!("{case}_in"));
        let img = image(&input);
        // Also the integer input path: the same values as u16.
        let img16 = img.map(|v| v as u16);
        for (bname, border) in [
            ("reflect101", Border::Reflect101),
            ("replicate", Border::Replicate),
        ] {
            for (op_name, op) in [
                ("filter2d", Operator::Central),
                ("sobel1", Operator::Central),
                ("sobel3", Operator::Sobel),
            ] {
                let spec = GradientSpec {
                    operator: op,
                    border,
                    serial: false,
                };
                let ours = gradients_from_image(&img.view(), &spec).unwrap();
                let ours16 = gradients_from_image(&img16.view(), &spec).unwrap();
                assert_eq!(ours, ours16);
                let gx = image(&load(&format!("{case}_{op_name}_{bname}_gx")));
                let gy = image(&load(&format!("{case}_{op_name}_{bname}_gy")));
                assert_eq!(ours.gx, gx, "{case} {op_name} {bname} gx");
                assert_eq!(ours.gy, gy, "{case} {op_name} {bname} gy");
                // The test can fail: the other border differs somewhere.
                let other = GradientSpec {
                    border: if border == Border::Reflect101 {
                        Border::Replicate
                    } else {
                        Border::Reflect101
                    },
                    ..spec
                };
                assert_ne!(gradients_from_image(&img.view(), &other).unwrap().gx, gx);
            }
        }
    }
}

#[test]
fn magnitude_and_phase_match_opencv() {
    for case in CASES {
        let img = image(&load(&format!("{case}_in")));
        let g = gradients_from_image(&img.view(), &GradientSpec::default()).unwrap();
        let mag = g.magnitude();
        let cv_mag = image(&load(&format!("{case}_mag")));
        for (a, b) in mag.as_slice().iter().zip(cv_mag.as_slice()) {
            assert!(
                (a - b).abs() <= 1e-6 * b.abs().max(1.0),
                "{case}: magnitude {a} vs {b}"
            );
        }
        let ph = g.orientation(AngleRange::Signed);
        let cv_ph = image(&load(&format!("{case}_phase")));
        let mut worst = 0f32;
        for ((a, b), m) in ph.as_slice().iter().zip(cv_ph.as_slice()).zip(mag.as_slice()) {
            if *m == 0.0 {
                continue; // both 0 by convention; nothing to compare
            }
            let d = (a - b).abs();
            worst = worst.max(d.min(360.0 - d));
        }
        assert!(worst <= 0.05, "{case}: phase differs by up to {worst}°");

        // The fused integer kernel against OpenCV's magnitude.
        let bits = if case == "kodak" { 8 } else { 14 };
        let frame = RawFrame::from_u16(
            img.width(),
            img.height(),
            img.as_slice().iter().map(|&v| v as u16).collect(),
            Cfa::Rggb,
            bits,
            Levels::uniform(0, ((1u32 << bits) - 1) as u16),
        )
        .unwrap();
        let spec = MagBinSpec::new(MagBinOptions::default()).unwrap();
        let mb = mag_bin_from_raw(&frame, &spec).unwrap();
        assert_eq!(mb.mag_shift, 0);
        for (a, b) in mb.mag.as_slice().iter().zip(cv_mag.as_slice()) {
            assert!(
                (*a as f32 - b).abs() <= 0.5 + b / 1024.0,
                "{case}: fused magnitude {a} vs OpenCV {b}"
            );
        }
        // Fused 9-bin unsigned orientation vs OpenCV's phase folded to 0–180°, away from edges.
        for ((&bin, &p), &m) in mb
            .bin
            .as_slice()
            .iter()
            .zip(cv_ph.as_slice())
            .zip(cv_mag.as_slice())
        {
            if m == 0.0 {
                assert_eq!(bin, 0);
                continue;
            }
            let u = p % 180.0;
            let pos = u / 20.0;
            if (pos - pos.round()).abs() * 20.0 > 0.1 {
                assert_eq!(bin as u32, pos.floor() as u32 % 9, "{case}: bin of phase {p}");
            }
        }
    }
}

#[test]
fn grey_is_bit_exact_with_opencv() {
    let rgb = load("grey_rgb");
    let want = load("grey_out");
    assert_eq!(rgb.shape.len(), 3);
    let (h, w) = (rgb.shape[0], rgb.shape[1]);
    let img = Image::from_fn(w, h, |x, y| {
        let i = (y * w + x) * 3;
        [rgb.data[i] as u8, rgb.data[i + 1] as u8, rgb.data[i + 2] as u8]
    });
    let ours = grey_from_rgb_u8(&img.view());
    let theirs: Vec<u8> = want.data.iter().map(|&v| v as u8).collect();
    assert_eq!(ours.as_slice(), theirs.as_slice());
}
