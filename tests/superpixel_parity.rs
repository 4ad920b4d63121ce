//! Parity of the super-pixel building blocks with OpenCV (fixtures from tests/oracle/gen_superpixel.py).

mod common;

use common::{max_abs_diff, oracle_image};
use mosaicd::features::superpixel::{gaussian_blur, GaussianKernel};
use mosaicd::image::Image;
use mosaicd::resize::resize_bilinear;

/// f32 accumulation order and OpenCV's float interpolation weights differ from ours in the last
/// bits: allow 1e-5 on values in [0, 1) (observed: ≤ 3.1e-6).
const TOL: f32 = 1e-5;

#[test]
fn gaussian_blur_matches_cv2_from_sigma() {
    let src = oracle_image("superpixel_src.npy");
    for s in ["0.8", "1.6", "2.5"] {
        let want = oracle_image(&format!("superpixel_blur_s{s}.npy"));
        let mut got = Image::new(0, 0);
        gaussian_blur(
            src.view(),
            &GaussianKernel::from_sigma(s.parse().unwrap()).unwrap(),
            &mut got,
        )
        .unwrap();
        let d = max_abs_diff(&got, &want);
        assert!(d < TOL, "sigma {s}: max |diff| {d}");
    }
}

#[test]
fn gaussian_blur_matches_cv2_from_ksize() {
    let src = oracle_image("superpixel_src.npy");
    for k in [3usize, 5, 9] {
        let want = oracle_image(&format!("superpixel_blur_k{k}.npy"));
        let mut got = Image::new(0, 0);
        gaussian_blur(
            src.view(),
            &GaussianKernel::from_ksize_opencv(k).unwrap(),
            &mut got,
        )
        .unwrap();
        let d = max_abs_diff(&got, &want);
        assert!(d < TOL, "ksize {k}: max |diff| {d}");
    }
}

#[test]
fn resize_matches_cv2_inter_linear() {
    let src = oracle_image("superpixel_src.npy");
    for (w, h) in [(41, 30), (120, 90), (79, 58), (166, 122), (30, 61)] {
        let want = oracle_image(&format!("superpixel_resize_{w}x{h}.npy"));
        let mut got = Image::new(0, 0);
        resize_bilinear(src.view(), w, h, &mut got).unwrap();
        let d = max_abs_diff(&got, &want);
        assert!(d < TOL, "{w}x{h}: max |diff| {d}");
    }
}
