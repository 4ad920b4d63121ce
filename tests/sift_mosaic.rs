//! Mosaic SIFT on real data: repeatability next to grey SIFT on Kodak, the daemon entry point on
//! a real raw frame, determinism across thread counts, and 16-bit extremes.

use mosaicd::eval::{
    grey_from_rgb8, grey_transformed, ground_truth, mosaic_transformed, rggb_mosaic_from_rgb8, score_pair,
    PlaneWarp, Transform, MATCH_THRESHOLD_PX,
};
use mosaicd::features::sift::{detect_and_compute, keypoints_from_frame, SiftSpec};
use mosaicd::image::Image;
use mosaicd::raw::{Cfa, Levels, RawFrame};

/// Smallest acceptable mosaic repeatability on kodim09 (measured 0.56–0.64 for these levels).
const MIN_MOSAIC_REPEATABILITY: f64 = 0.45;
/// Largest acceptable shortfall against grey SIFT on one image (measured 0.06–0.09; the Kodak
/// means over images are within 0.05, see docs/sift.md).
const MAX_SHORTFALL: f64 = 0.15;

#[test]
fn mosaic_repeatability_is_close_to_grey_on_kodim09() {
    let path = mosaicd::data::require("kodak/kodim09.png");
    let rgb = mosaicd::image_io::load_rgb8(&path).unwrap();
    let grey = grey_from_rgb8(&rgb);
    let mosaic = rggb_mosaic_from_rgb8(&rgb);
    let (gs, ms) = (SiftSpec::grey(), SiftSpec::mosaic());
    let g1 = detect_and_compute(grey.view(), &gs).unwrap();
    let m1 = detect_and_compute(mosaic.view(), &ms).unwrap();
    for t in [Transform::Rotate(30.0), Transform::Scale(0.75)] {
        let g2i = grey_transformed(&grey, t);
        let m2i = mosaic_transformed(&mosaic, t, PlaneWarp::OwnCentre);
        let g2 = detect_and_compute(g2i.view(), &gs).unwrap();
        let m2 = detect_and_compute(m2i.view(), &ms).unwrap();
        let h = ground_truth(t, grey.width(), grey.height());
        let (g, _) = score_pair(
            &g1,
            grey.dimensions(),
            &g2,
            g2i.dimensions(),
            &h,
            MATCH_THRESHOLD_PX,
        );
        let (m, _) = score_pair(
            &m1,
            mosaic.dimensions(),
            &m2,
            m2i.dimensions(),
            &h,
            MATCH_THRESHOLD_PX,
        );
        eprintln!(
            "{t:?}: grey {:.3} ({} correct), mosaic {:.3} ({} correct)",
            g.repeatability, g.correct, m.repeatability, m.correct
        );
        assert!(
            m.repeatability >= MIN_MOSAIC_REPEATABILITY,
            "{t:?}: mosaic {}",
            m.repeatability
        );
        assert!(
            m.repeatability >= g.repeatability - MAX_SHORTFALL,
            "{t:?}: mosaic {} vs grey {}",
            m.repeatability,
            g.repeatability
        );
    }
}

fn nikon() -> RawFrame {
    let path = mosaicd::data::require("raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw");
    let bytes = std::fs::read(path).unwrap();
    let data: Vec<u16> = bytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect();
    RawFrame::from_u16(768, 512, data, Cfa::Rggb, 14, Levels::uniform(600, 15520)).unwrap()
}

#[test]
fn keypoints_from_a_real_raw_frame_are_deterministic_and_inside() {
    let frame = nikon();
    let spec = SiftSpec::mosaic();
    let a = keypoints_from_frame(&frame, &spec).unwrap();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let b = pool.install(|| keypoints_from_frame(&frame, &spec).unwrap());
    assert_eq!(a, b);
    assert!(a.len() > 50, "only {} keypoints on the Nikon frame", a.len());
    for k in &a {
        assert!(k.x >= 0.0 && k.y >= 0.0 && k.x <= 767.0 && k.y <= 511.0, "{k:?}");
        assert!(k.size > 0.0 && (0.0..360.0).contains(&k.angle) && k.response.is_finite());
    }
    // Total order: sorted by x, then y.
    assert!(a.windows(2).all(|w| (w[0].x, w[0].y) <= (w[1].x, w[1].y)));
}

#[test]
fn sixteen_bit_extremes_give_finite_results() {
    // Saturated blocks next to black on a full-range u16 mosaic.
    let img = Image::from_fn(96, 80, |x, y| {
        if ((x / 12) + (y / 10)) % 2 == 0 {
            65535u16
        } else {
            0
        }
    });
    let spec = SiftSpec::mosaic().with_max_value(65535.0).unwrap();
    let f = detect_and_compute(img.view(), &spec).unwrap();
    for k in &f.keypoints {
        assert!(k.x.is_finite() && k.y.is_finite() && k.size.is_finite());
    }
    let flat = Image::filled(96, 80, 65535u16);
    assert!(detect_and_compute(flat.view(), &spec)
        .unwrap()
        .keypoints
        .is_empty());
    // A frame whose white level equals its black level is clamped, not divided by zero.
    let frame = RawFrame::from_u16(
        64,
        64,
        vec![4095; 64 * 64],
        Cfa::Rggb,
        12,
        Levels::uniform(4095, 4095),
    );
    if let Ok(frame) = frame {
        assert!(keypoints_from_frame(&frame, &SiftSpec::mosaic())
            .unwrap()
            .is_empty());
    }
}

/// A quarter turn of the whole frame, `(x, y) -> (h - 1 - y, x)`: a lossless permutation of the
/// pixels (the CFA pattern turns with them).
fn quarter_turn(img: &Image<f32>) -> Image<f32> {
    let (w, h) = img.dimensions();
    Image::from_fn(h, w, |x, y| img.get(y, h - 1 - x))
}

#[test]
fn centred_octaves_make_mosaic_keypoints_turn_exactly_with_the_frame() {
    let path = mosaicd::data::require("kodak/kodim09.png");
    let mosaic = rggb_mosaic_from_rgb8(&mosaicd::image_io::load_rgb8(&path).unwrap());
    let h = mosaic.height();
    let turned = quarter_turn(&mosaic);
    // Fraction of the keypoints of octave >= 1 whose turned position is a keypoint of the
    // turned mosaic (within 0.01 px).
    let coarse_found = |spec: &SiftSpec| {
        let a = mosaicd::features::sift::detect(mosaic.view(), spec).unwrap();
        let b = mosaicd::features::sift::detect(turned.view(), spec).unwrap();
        let coarse: Vec<_> = a.iter().filter(|k| k.octave >= 1).collect();
        let found = coarse
            .iter()
            .filter(|k| {
                let (x, y) = ((h - 1) as f32 - k.y, k.x);
                b.iter()
                    .any(|q| (q.x - x).hypot(q.y - y) < 0.01 && q.octave == k.octave)
            })
            .count();
        (a.len(), b.len(), coarse.len(), found)
    };
    let (n1, n2, coarse, found) = coarse_found(&SiftSpec::mosaic());
    eprintln!("centred: {n1} / {n2} keypoints, {found} of {coarse} coarse found");
    // Measured: 149 / 149, 53 of 53.
    assert_eq!(n1, n2);
    assert!(coarse >= 20, "{coarse} coarse keypoints");
    assert_eq!(found, coarse);
    let (n1, n2, coarse, found) = coarse_found(&SiftSpec::mosaic().with_centred_octaves(false));
    eprintln!("every other super-pixel: {n1} / {n2} keypoints, {found} of {coarse} coarse found");
    // Measured: 0 of 51: the turned frame's octave grid is one sample off.
    assert!(found * 2 < coarse, "{found} of {coarse}");
}
