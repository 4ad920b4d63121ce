//! Parity of MSE / PSNR / SSIM with scikit-image on Kodak images, and of the Xue et al. 2014 GMSD
//! with an independent numpy/scipy transcription of their GMSD.m (fixtures by
//! tests/oracle/gen_metrics.py: run `make oracle`).

use mosaicd::image::Image;
use mosaicd::metrics::{gmsd_xue2014, mse, mssim, mssim_per_channel, psnr, ssim_map, SsimOptions};
use mosaicd::npy::NpyArray;
use std::path::PathBuf;

/// SSIM tolerance the brief asks for.
const SSIM_TOL: f64 = 1e-4;
/// PSNR tolerance in dB (both sides sum the same f32 values in f64).
const PSNR_TOL: f64 = 1e-6;
const IMAGES: [&str; 4] = ["kodim01", "kodim05", "kodim13", "kodim23"];

fn oracle_dir() -> PathBuf {
    let dir = std::env::var_os("MOSAICD_ORACLE")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/oracle"));
    let probe = dir.join("metrics.json");
    assert!(
        probe.exists(),
        "oracle fixture {} is missing: run `make oracle` (python3 tests/oracle/generate.py --out target/oracle)",
        probe.display()
    );
    dir
}

fn npy_grey(path: PathBuf) -> Image<f32> {
    let a = NpyArray::read(&path).unwrap_or_else(|e| panic!("{e} (run `make oracle`)"));
    assert_eq!(a.shape.len(), 2, "{}", path.display());
    Image::from_vec(a.shape[1], a.shape[0], a.data.iter().map(|&v| v as f32).collect()).unwrap()
}

fn npy_rgb(path: PathBuf) -> Image<[f32; 3]> {
    let a = NpyArray::read(&path).unwrap_or_else(|e| panic!("{e} (run `make oracle`)"));
    assert_eq!(a.shape.len(), 3, "{}", path.display());
    let px = a
        .data
        .chunks_exact(3)
        .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
        .collect();
    Image::from_vec(a.shape[1], a.shape[0], px).unwrap()
}

fn kodak_rgb(name: &str) -> Image<[f32; 3]> {
    let p = mosaicd::data::require(&format!("kodak/{name}.png"));
    let img = image::open(&p).unwrap().to_rgb8();
    let (w, h) = img.dimensions();
    let px = img
        .pixels()
        .map(|p| [p.0[0] as f32, p.0[1] as f32, p.0[2] as f32])
        .collect();
    Image::from_vec(w as usize, h as usize, px).unwrap()
}

fn channel(img: &Image<[f32; 3]>, c: usize) -> Image<f32> {
    img.map(|p| p[c])
}

#[test]
fn ssim_psnr_mse_match_skimage_on_kodak() {
    let dir = oracle_dir();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("metrics.json")).unwrap()).unwrap();
    let range = json["data_range"].as_f64().unwrap();
    let spec = SsimOptions::with_data_range(range).build().unwrap();
    let mut worst_ssim = 0.0f64;
    let mut worst_psnr = 0.0f64;
    for name in IMAGES {
        let e = &json["images"][name];
        let r = kodak_rgb(name);
        let d = npy_rgb(dir.join(format!("metrics_{name}_dist_rgb.npy")));
        let gr = npy_grey(dir.join(format!("metrics_{name}_grey_ref.npy")));
        let gd = npy_grey(dir.join(format!("metrics_{name}_grey_dist.npy")));

        let s = mssim(gr.view(), gd.view(), &spec).unwrap();
        let want = e["grey"]["ssim"].as_f64().unwrap();
        worst_ssim = worst_ssim.max((s - want).abs());
        assert!(
            (s - want).abs() < SSIM_TOL,
            "{name} grey SSIM {s} vs skimage {want}"
        );
        let p = psnr(gr.view(), gd.view(), range).unwrap();
        let want = e["grey"]["psnr"].as_f64().unwrap();
        worst_psnr = worst_psnr.max((p - want).abs());
        assert!(
            (p - want).abs() < PSNR_TOL,
            "{name} grey PSNR {p} vs skimage {want}"
        );
        let m = mse(gr.view(), gd.view()).unwrap();
        let want = e["grey"]["mse"].as_f64().unwrap();
        assert!(
            (m - want).abs() < 1e-9 * want.max(1.0),
            "{name} grey MSE {m} vs skimage {want}"
        );

        let g = gmsd_xue2014(gr.view(), gd.view()).unwrap();
        let want = e["grey"]["gmsd_xue2014"].as_f64().unwrap();
        assert!(
            (g - want).abs() < 1e-9,
            "{name} GMSD (Xue 2014) {g} vs numpy/scipy {want}"
        );

        let s = mssim(r.view(), d.view(), &spec).unwrap();
        let want = e["rgb"]["ssim"].as_f64().unwrap();
        worst_ssim = worst_ssim.max((s - want).abs());
        assert!(
            (s - want).abs() < SSIM_TOL,
            "{name} RGB SSIM {s} vs skimage {want}"
        );
        let p = psnr(r.view(), d.view(), range).unwrap();
        let want = e["rgb"]["psnr"].as_f64().unwrap();
        assert!(
            (p - want).abs() < PSNR_TOL,
            "{name} RGB PSNR {p} vs skimage {want}"
        );

        let per = mssim_per_channel(r.view(), d.view(), &spec).unwrap();
        for c in 0..3 {
            let want = e["channels"][c]["ssim"].as_f64().unwrap();
            worst_ssim = worst_ssim.max((per[c] - want).abs());
            assert!(
                (per[c] - want).abs() < SSIM_TOL,
                "{name} channel {c} SSIM {} vs skimage {want}",
                per[c]
            );
            let p = psnr(channel(&r, c).view(), channel(&d, c).view(), range).unwrap();
            let want = e["channels"][c]["psnr"].as_f64().unwrap();
            worst_psnr = worst_psnr.max((p - want).abs());
            assert!(
                (p - want).abs() < PSNR_TOL,
                "{name} channel {c} PSNR {p} vs skimage {want}"
            );
        }
    }
    eprintln!("worst |SSIM - skimage| = {worst_ssim:.2e}, worst |PSNR - skimage| = {worst_psnr:.2e} dB");
}

#[test]
fn ssim_map_matches_skimage() {
    let dir = oracle_dir();
    let gr = npy_grey(dir.join("metrics_kodim01_grey_ref.npy"));
    let gd = npy_grey(dir.join("metrics_kodim01_grey_dist.npy"));
    let want = npy_grey(dir.join("metrics_kodim01_ssim_map.npy"));
    let spec = SsimOptions::with_data_range(255.0).build().unwrap();
    let got = ssim_map(gr.view(), gd.view(), &spec).unwrap();
    assert_eq!(got.dimensions(), want.dimensions());
    let worst = got
        .as_slice()
        .iter()
        .zip(want.as_slice())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    eprintln!("worst SSIM map difference = {worst:.2e}");
    // Every pixel, borders included (reflect padding as scipy's gaussian_filter).
    assert!(f64::from(worst) < SSIM_TOL, "worst SSIM map difference {worst}");
}
