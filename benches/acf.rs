//! The ACF detector on a 1920x1080 12-bit mosaic: channel pyramid and scoring times per frame
//! (the daemon's steady state: one detector, frames one after the other, buffers warm).
//!
//! ```sh
//! MOSAICD_KERNELS=avx2 MOSAICD_ACF_MODEL=model.json [MOSAICD_ACF_RAW=frame.raw] \
//!   cargo bench --bench acf
//! ```
//! `MOSAICD_ACF_RAW`: 1920x1080 RGGB, 16-bit little-endian words holding 12-bit values (a
//! synthetic scene otherwise). `MOSAICD_BENCH_THREADS`: threads (2). Without a model only the
//! channel pyramid is timed.

use std::time::{Duration, Instant};

use mosaicd::detect::MosaicPrep;
use mosaicd::detect::{pyramid, ChannelInput, ChannelSpec, PyramidOptions};
use mosaicd::detect::{AcfDetector, AcfModel, AcfOptions};
use mosaicd::raw::{Cfa, Levels, RawFrame};

const RUNS: usize = 12;

fn median(mut v: Vec<Duration>) -> f64 {
    v.sort();
    v[v.len() / 2].as_secs_f64() * 1e3
}

fn main() {
    let (w, h) = (1920usize, 1080usize);
    let px: Vec<u16> = match std::env::var("MOSAICD_ACF_RAW") {
        Ok(p) => std::fs::read(&p)
            .unwrap_or_else(|e| panic!("{p}: {e}"))
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect(),
        Err(_) => (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let v = (x * 0.013).sin() * (y * 0.021).cos() * 1500.0 + 2000.0 + ((i * 7919) % 97) as f32;
                v as u16 & 4095
            })
            .collect(),
    };
    let frame = RawFrame::from_u16(w, h, px, Cfa::Rggb, 12, Levels::uniform(0, 4095)).expect("frame");
    let mosaic = MosaicPrep::default().mosaic(&frame).expect("mosaic");
    let input = ChannelInput::Mosaic {
        image: mosaic.view(),
        cfa: Cfa::Rggb,
    };
    let threads: usize = std::env::var("MOSAICD_BENCH_THREADS")
        .ok()
        .and_then(|t| t.parse().ok())
        .unwrap_or(2);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    println!(
        "{}; {threads} threads; 1920x1080 12-bit mosaic",
        mosaicd::kernels::describe()
    );
    match std::env::var("MOSAICD_ACF_MODEL") {
        Err(_) => {
            let spec = ChannelSpec::default();
            let opts = PyramidOptions::default();
            let times: Vec<Duration> = (0..RUNS)
                .map(|_| {
                    let t = Instant::now();
                    pool.install(|| pyramid(&input, &spec, &opts)).unwrap();
                    t.elapsed()
                })
                .collect();
            println!(
                "channel pyramid: median {:.1} ms over {RUNS} frames",
                median(times[2..].to_vec())
            );
        }
        Ok(path) => {
            let model = AcfModel::load(std::path::Path::new(&path)).unwrap();
            let det = AcfDetector::new(model, &AcfOptions::default()).unwrap();
            let (mut ch, mut sc, mut tot) = (vec![], vec![], vec![]);
            let mut per_window = 0.0;
            for i in 0..RUNS {
                let (_, st) = pool.install(|| det.detect_raw(&input)).unwrap();
                per_window = st.trees_evaluated as f64 / st.windows as f64;
                if i >= 2 {
                    ch.push(st.channels);
                    sc.push(st.score);
                    tot.push(st.total);
                }
            }
            println!(
                "{path}: median of {} frames: total {:.1} ms (channels + pyramid {:.1}, scoring {:.1}), {per_window:.1} trees per window",
                RUNS - 2,
                median(tot),
                median(ch),
                median(sc)
            );
        }
    }
}
