//! What the live view ([foxglove] listen) costs its sink thread per 1080p frame, one thread, on a
//! seeded synthetic 12-bit 1920x1080 mosaic: the `bayer_*8` preview as `foxglove.RawImage`
//! (decimation 2, the default, and 1) against the same preview demosaiced (bilinear) and
//! compressed to JPEG as a `foxglove.CompressedImage`; and the boxes as
//! `foxglove.ImageAnnotations`. Each row ends with the message encoded as the SDK sends it
//! (protobuf); the bytes per message are printed first.
//!
//! `cargo bench --bench live_view` (docs/daemon.md, "Live view in Foxglove", quotes a run).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use foxglove::messages::{CompressedImage, ImageAnnotations, RawImage};
use foxglove::Encode;
use mosaicd::features::gradient::synthetic_mosaic;
use mosaicd::geometry::Detection;
use mosaicd::image::Image;
use mosaicd::isp::rgb_from_mosaic_u8;
use mosaicd::isp::DemosaicMethod;
use mosaicd::raw::{Cfa, Levels, RawFrame};
use mosaicd::record::preview_from_raw;
use mosaicd::wire::schema::annotations_from_detections;

/// Seed of the synthetic scene.
const SEED: u64 = 2024;
/// JPEG quality of the compressed alternative.
const JPEG_QUALITY: u8 = 80;

fn encoded(msg: &impl Encode) -> Vec<u8> {
    let mut buf = Vec::with_capacity(msg.encoded_len().unwrap_or(0));
    msg.encode(&mut buf).unwrap();
    buf
}

fn raw_image(f: &RawFrame, d: usize) -> Vec<u8> {
    let pv = preview_from_raw(f, d).unwrap();
    encoded(&RawImage {
        timestamp: None,
        frame_id: "cam".into(),
        width: pv.width as u32,
        height: pv.height as u32,
        encoding: f.cfa().foxglove_encoding(false).into(),
        step: pv.width as u32,
        data: pv.data.into(),
    })
}

fn jpeg_image(f: &RawFrame, d: usize) -> Vec<u8> {
    let pv = preview_from_raw(f, d).unwrap();
    let mosaic = Image::from_vec(pv.width, pv.height, pv.data).unwrap();
    let rgb = rgb_from_mosaic_u8(mosaic.view(), f.cfa(), DemosaicMethod::Bilinear).unwrap();
    let flat: Vec<u8> = (0..pv.height)
        .flat_map(|y| (0..pv.width).map(move |x| (x, y)))
        .flat_map(|(x, y)| rgb.get(x, y))
        .collect();
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, JPEG_QUALITY)
        .encode(
            &flat,
            pv.width as u32,
            pv.height as u32,
            image::ExtendedColorType::Rgb8,
        )
        .unwrap();
    encoded(&CompressedImage {
        timestamp: None,
        frame_id: "cam".into(),
        data: jpeg.into(),
        format: "jpeg".into(),
    })
}

fn annotations(dets: &[Detection]) -> Vec<u8> {
    encoded(&ImageAnnotations::from(&annotations_from_detections(
        0, dets, 2.0,
    )))
}

fn bench(c: &mut Criterion) {
    // `cargo test --all-targets` runs this once in test mode: a small frame there.
    let bench_mode = std::env::args().any(|a| a == "--bench");
    let (w, h) = if bench_mode { (1920, 1080) } else { (64, 48) };
    let m = synthetic_mosaic(w, h, 12, SEED);
    let f = RawFrame::from_u16(
        w,
        h,
        m.as_slice().to_vec(),
        Cfa::Grbg,
        12,
        Levels::uniform(64, 4095),
    )
    .unwrap();
    let dets: Vec<Detection> = (0..20)
        .map(|i| Detection {
            x: 40.0 * i as f32,
            y: 10.0 * i as f32,
            width: 64.0,
            height: 128.0,
            score: 1.0,
        })
        .collect();
    eprintln!(
        "{w}x{h} 12-bit: RawImage d2 {} B, d1 {} B; JPEG q{JPEG_QUALITY} d2 {} B, d1 {} B; 20 boxes {} B",
        raw_image(&f, 2).len(),
        raw_image(&f, 1).len(),
        jpeg_image(&f, 2).len(),
        jpeg_image(&f, 1).len(),
        annotations(&dets).len()
    );
    let mut g = c.benchmark_group("live_view");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(3));
    g.warm_up_time(std::time::Duration::from_millis(500));
    for d in [2, 1] {
        g.bench_function(format!("raw_image_d{d}"), |b| {
            b.iter(|| raw_image(black_box(&f), d))
        });
        g.bench_function(format!("jpeg_d{d}"), |b| b.iter(|| jpeg_image(black_box(&f), d)));
    }
    g.bench_function("annotations_20_boxes", |b| {
        b.iter(|| annotations(black_box(&dets)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
