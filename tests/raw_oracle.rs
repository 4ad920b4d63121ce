//! Parity of RGB → mosaic sampling with colour-demosaicing's `mosaicing_CFA_Bayer`, and of our
//! physical pattern names with OpenCV's shifted Bayer codes (fixtures from
//! tests/oracle/gen_raw.py; run `make oracle` first).

mod common;

use common::{oracle, oracle_dir};
use mosaicd::image::Image;
use mosaicd::raw::{mosaic_from_rgb, Cfa};

#[test]
fn mosaic_from_rgb_matches_colour_demosaicing_for_all_patterns() {
    let rgb = oracle("raw_rgb.npy");
    assert_eq!(rgb.shape.len(), 3, "raw_rgb.npy shape {:?}", rgb.shape);
    let (h, w) = (rgb.shape[0], rgb.shape[1]);
    let px: Vec<[u8; 3]> = rgb
        .data
        .chunks_exact(3)
        .map(|c| [c[0] as u8, c[1] as u8, c[2] as u8])
        .collect();
    let img = Image::from_vec(w, h, px).unwrap();
    for cfa in Cfa::ALL {
        let want = oracle(&format!("raw_mosaic_{}.npy", cfa.name()));
        assert_eq!(want.shape, vec![h, w]);
        let got = mosaic_from_rgb(&img.view(), cfa);
        // Exact: both only pick a channel.
        for (i, (&g, &e)) in got.as_slice().iter().zip(&want.data).enumerate() {
            assert_eq!(g as f64, e, "{cfa} at ({}, {})", i % w, i / w);
        }
    }
}

#[test]
fn opencv_code_names_match_what_cv2_demosaics_correctly() {
    let p = oracle_dir().join("raw_opencv_names.json");
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| {
        panic!(
            "{}: {e}: run `make oracle` (python3 tests/oracle/generate.py --out target/oracle) first",
            p.display()
        )
    });
    let names: std::collections::HashMap<String, String> = serde_json::from_str(&text).unwrap();
    for cfa in Cfa::ALL {
        assert_eq!(
            names.get(cfa.name()).map(String::as_str),
            Some(cfa.opencv_code_name()),
            "{cfa}"
        );
    }
}
