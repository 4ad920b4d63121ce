//! Criterion benches of the HOG block grid and the full detector on a synthetic 1080p mosaic
//! (the comparison with OpenCV is `mosaicd bench detect`).

use criterion::{criterion_group, criterion_main, Criterion};
use mosaicd::detect::{Detector, DetectorOptions, Domain, LinearModel};
use mosaicd::features::hog::{block_grid, BlockGrid, Exec, HogInput, HogOptions, HogSpec};
use mosaicd::image::Image;

fn scene(w: usize, h: usize) -> Image<f32> {
    // Deterministic textured mosaic in 8-bit units.
    Image::from_fn(w, h, |x, y| {
        let v = ((x as f32 * 0.05).sin() * (y as f32 * 0.031).cos() * 100.0 + 128.0)
            + ((x * 7 + y * 13) % 17) as f32;
        v * if (x + y) % 2 == 0 { 1.0 } else { 0.8 }
    })
}

fn bench(c: &mut Criterion) {
    let img = scene(1920, 1080);
    let spec = HogSpec::new(&HogOptions::default()).unwrap();
    let mut grid = BlockGrid::empty();
    c.bench_function("hog block grid 1080p mosaic (one level)", |b| {
        b.iter(|| block_grid(&spec, &HogInput::Mosaic(img.view()), Exec::Parallel, &mut grid).unwrap())
    });
    let w: Vec<f32> = (0..3781).map(|i| ((i * 37 % 101) as f32 - 50.0) * 1e-3).collect();
    let model = LinearModel::from_opencv_vector(&w, Domain::Mosaic, "bench").unwrap();
    for approx in [1, 14] {
        let det = Detector::new(
            model.clone(),
            &DetectorOptions {
                approx_levels: approx,
                ..Default::default()
            },
        )
        .unwrap();
        c.bench_function(&format!("detect 1080p mosaic, 44 levels, approx {approx}"), |b| {
            b.iter(|| det.detect(&HogInput::Mosaic(img.view())).unwrap())
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
