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

/// Raw frame → the detector's mosaic (the daemon's first detection step), 1080p 12- and 16-bit:
/// linear into a reused buffer, srgb tables built, srgb applied with tables kept.
fn bench_mosaic(c: &mut Criterion) {
    use mosaicd::features::hog::{mosaic_from_raw_into, MosaicTone, ToneTables};
    use mosaicd::raw::{Cfa, Levels, RawFrame};
    let (w, h) = (1920usize, 1080usize);
    for bits in [12u8, 16] {
        let max = ((1u32 << bits) - 1) as u16;
        let px: Vec<u16> = (0..w * h)
            .map(|i| (i.wrapping_mul(2654435761) >> 7) as u16 & max)
            .collect();
        let f = RawFrame::from_u16(w, h, px, Cfa::Rggb, bits, Levels::uniform(256, max)).unwrap();
        let mut buf = Vec::new();
        c.bench_function(&format!("raw -> linear mosaic 1080p {bits}-bit"), |b| {
            b.iter(|| mosaic_from_raw_into(&f, 64, &mut buf))
        });
        let gains = [1.8, 1.0, 1.4];
        c.bench_function(&format!("srgb tone tables {bits}-bit (build)"), |b| {
            b.iter(|| ToneTables::new(&f, MosaicTone::Srgb, gains))
        });
        let t = ToneTables::new(&f, MosaicTone::Srgb, gains);
        c.bench_function(
            &format!("raw -> srgb mosaic 1080p {bits}-bit (tables kept)"),
            |b| b.iter(|| t.apply_into(&f, 64, &mut buf)),
        );
    }
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
    targets = bench_mosaic, bench
}
criterion_main!(benches);
