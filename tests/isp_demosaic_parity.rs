//! Demosaicing parity with colour-demosaicing (bilinear, Malvar 2004) and OpenCV (bilinear) on a
//! Kodak crop, for all four patterns. Fixtures come from tests/oracle/gen_isp.py (`make oracle`).

use std::path::PathBuf;

use mosaicd::image::Image;
use mosaicd::isp::{rgb_from_mosaic, rgb_from_mosaic_u8, DemosaicMethod};
use mosaicd::npy::NpyArray;
use mosaicd::raw::Cfa;

fn oracle_dir() -> PathBuf {
    std::env::var_os("MOSAICD_ORACLE")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/oracle"))
        .join("isp")
}

fn fixture(name: &str) -> NpyArray {
    let p = oracle_dir().join(name);
    NpyArray::read(&p).unwrap_or_else(|e| {
        panic!(
            "oracle fixture {} missing or unreadable ({e}): run `make oracle` (tests/oracle/gen_isp.py) first",
            p.display()
        )
    })
}

fn mosaic(cfa: Cfa) -> Image<f32> {
    let a = fixture(&format!("mosaic_{}.npy", cfa.name()));
    let (h, w) = (a.shape[0], a.shape[1]);
    Image::from_vec(w, h, a.data.iter().map(|&v| v as f32).collect()).unwrap()
}

/// Largest |ours − reference| over pixels at least `margin` from every border.
fn max_interior_diff(ours: &Image<[f32; 3]>, reference: &NpyArray, margin: usize) -> f64 {
    let (w, h) = ours.dimensions();
    assert_eq!(reference.shape, vec![h, w, 3]);
    let mut worst = 0f64;
    for y in margin..h - margin {
        for x in margin..w - margin {
            let p = ours.get(x, y);
            for (c, &v) in p.iter().enumerate() {
                let r = reference.data[(y * w + x) * 3 + c];
                worst = worst.max((v as f64 - r).abs());
            }
        }
    }
    worst
}

#[test]
fn bilinear_equals_colour_demosaicing_away_from_borders() {
    // margin 1 (3x3 kernel; colour-demosaicing reflects with edge repeat, we mirror without);
    // tolerance 1e-6 on [0, 1] (f32 vs f64 arithmetic).
    for cfa in Cfa::ALL {
        let m = mosaic(cfa);
        let ours = rgb_from_mosaic(m.view(), cfa, DemosaicMethod::Bilinear).unwrap();
        let d = max_interior_diff(&ours, &fixture(&format!("bilinear_{}.npy", cfa.name())), 1);
        assert!(d < 1e-6, "{cfa}: max diff {d}");
    }
}

#[test]
fn malvar_equals_colour_demosaicing_away_from_borders() {
    // margin 2 (5x5 kernels), tolerance 1e-6 on [0, 1].
    for cfa in Cfa::ALL {
        let m = mosaic(cfa);
        let ours = rgb_from_mosaic(m.view(), cfa, DemosaicMethod::Malvar).unwrap();
        let d = max_interior_diff(&ours, &fixture(&format!("malvar_{}.npy", cfa.name())), 2);
        assert!(d < 1e-6, "{cfa}: max diff {d}");
    }
}

#[test]
fn bilinear_u8_equals_opencv_away_from_borders() {
    // OpenCV COLOR_Bayer??2RGB (shifted names: Cfa::opencv_code_name) on the u8 mosaic.
    // margin 2 (OpenCV treats its border separately); tolerance: at most 1 grey level (rounding of
    // exact .5 averages could differ), and at most 0.1 % of the interior values may differ at all
    // (measured with OpenCV 4.14: none differ).
    for cfa in Cfa::ALL {
        let m = mosaic(cfa);
        let m8 = m.map(|v| (v * 255.0).round() as u8);
        let ours = rgb_from_mosaic_u8(m8.view(), cfa, DemosaicMethod::Bilinear).unwrap();
        let cv = fixture(&format!("opencv_bilinear_{}.npy", cfa.name()));
        let (w, h) = ours.dimensions();
        let (mut worst, mut differ, mut n) = (0i32, 0usize, 0usize);
        for y in 2..h - 2 {
            for x in 2..w - 2 {
                for c in 0..3 {
                    let d = (ours.get(x, y)[c] as i32 - cv.data[(y * w + x) * 3 + c] as i32).abs();
                    worst = worst.max(d);
                    differ += (d != 0) as usize;
                    n += 1;
                }
            }
        }
        eprintln!(
            "{cfa} ({}): max diff {worst}, {differ} of {n} differ",
            cfa.opencv_code_name()
        );
        assert!(worst <= 1, "{cfa}: max diff {worst}");
        assert!(differ * 1000 <= n, "{cfa}: {differ} of {n} values differ");
    }
}
