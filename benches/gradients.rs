//! Fused raw mosaic → u16 magnitude + u8 orientation bin, one thread, on seeded synthetic mosaics
//! (1080p and 12 MP, 8-bit and 12-bit), next to the memory-bandwidth floor: a plain copy of the
//! input plus a write of the output (3 bytes per pixel). The `fused_*` rows run the process's kernel
//! path (printed first; `MOSAICD_KERNELS` forces one), the `path_*` rows each path this CPU has.
//!
//! `cargo bench --bench gradients`. The comparison with OpenCV in the same run is
//! `mosaicd bench gradients` (see docs/gradients.md).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mosaicd::features::gradient::{
    mag_bin, mag_bin_with_isa, synthetic_mosaic, MagBinOptions, MagBinSpec, Operator,
};
use mosaicd::image::Image;
use mosaicd::kernels::{self, Isa};
use mosaicd::raw::RawView;

/// Frame sizes: 1080p and 12 MP.
const SIZES: [(&str, usize, usize); 2] = [("1080p", 1920, 1080), ("12MP", 4000, 3000)];
/// Bit depths: 8-bit (u8 container) and 12-bit (u16 container).
const BITS: [u8; 2] = [8, 12];
/// Seed of the synthetic scene.
const SEED: u64 = 2024;

fn bench(c: &mut Criterion) {
    // The `fused_*` rows run the process's path; name it.
    eprintln!("{}", kernels::describe());
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let mut g = c.benchmark_group("gradients");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(3));
    g.warm_up_time(std::time::Duration::from_millis(500));
    // `cargo test --all-targets` runs this once in test mode (no `--bench`): keep that smoke run
    // cheap with a small frame instead of generating 12 MP in the dev profile.
    let bench_mode = std::env::args().any(|a| a == "--bench");
    let sizes: &[(&str, usize, usize)] = if bench_mode { &SIZES } else { &[("smoke", 64, 48)] };
    for &(name, w, h) in sizes {
        let m16 = synthetic_mosaic(w, h, 12, SEED);
        let m8 = m16.map(|v| (v >> 4) as u8);
        for bits in BITS {
            let src = if bits == 8 {
                RawView::U8(m8.view())
            } else {
                RawView::U16(m16.view())
            };
            let in_bytes = w * h * if bits == 8 { 1 } else { 2 };
            g.throughput(Throughput::Elements((w * h) as u64));
            let mut mag = Image::<u16>::new(w, h);
            let mut bin = Image::<u8>::new(w, h);
            for op in [Operator::Central, Operator::Sobel] {
                let spec = MagBinSpec::new(MagBinOptions {
                    operator: op,
                    ..Default::default()
                })
                .unwrap();
                let id = BenchmarkId::new(
                    format!("fused_{op:?}_1thread").to_lowercase(),
                    format!("{name}_{bits}bit"),
                );
                g.bench_function(id, |b| {
                    b.iter(|| {
                        pool.install(|| {
                            mag_bin(src, bits, &spec, &mut mag.view_mut(), &mut bin.view_mut()).unwrap();
                        });
                        black_box((&mag, &bin));
                    })
                });
            }
            // Each kernel path of the same kernel (1080p only, to keep the run short).
            if name == "1080p" {
                let spec = MagBinSpec::new(MagBinOptions::default()).unwrap();
                for path in Isa::available() {
                    let id = BenchmarkId::new(format!("path_{path}_central"), format!("{name}_{bits}bit"));
                    g.bench_function(id, |b| {
                        b.iter(|| {
                            pool.install(|| {
                                mag_bin_with_isa(
                                    src,
                                    bits,
                                    &spec,
                                    path,
                                    &mut mag.view_mut(),
                                    &mut bin.view_mut(),
                                )
                                .unwrap();
                            });
                            black_box((&mag, &bin));
                        })
                    });
                }
            }
            // Bandwidth floor: read the input once, write the 3 output bytes per pixel once.
            let input: Vec<u8> = vec![1; in_bytes];
            let mut in_copy = vec![0u8; in_bytes];
            let out_src = vec![2u8; w * h * 3];
            let mut out_copy = vec![0u8; w * h * 3];
            g.bench_function(
                BenchmarkId::new("memcpy_in_plus_out", format!("{name}_{bits}bit")),
                |b| {
                    b.iter(|| {
                        in_copy.copy_from_slice(black_box(&input));
                        out_copy.copy_from_slice(black_box(&out_src));
                        black_box((&in_copy, &out_copy));
                    })
                },
            );
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
