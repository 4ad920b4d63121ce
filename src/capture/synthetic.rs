//! A deterministic synthetic source: a moving scene rendered straight into a Bayer mosaic.
//!
//! Used by tests and `mosaicd bench pipeline` (a 1080p 12-bit stream needs no data files), and as
//! `source = "synthetic"` in a config. The scene is a set of bright bars and a gradient ramp that
//! move two pixels per frame, sampled through the CFA (the colour of each pixel's filter picks a
//! channel gain), plus a fixed-seed hash "noise"; frame `n` is a pure function of `n` and the
//! parameters. Timestamps advance by `1/fps`. As a replay source it is back-pressured; with
//! `live = true` it paces itself at `fps` and is treated as a camera (drop-oldest).
//!
//! Pixel buffers come from a [`BufferPool`] the pipeline refills, so a steady stream allocates
//! nothing per frame. Rendering costs CPU a camera does not (≈ 10 ms per 1080p frame, in f64):
//! [`SyntheticSource::prerender`] renders a cycle of frames once, and the stream then copies
//! them into pooled buffers, as a camera's frames are copied out of its DMA buffers (what
//! `mosaicd bench pipeline` measures the daemon with).
//!
//! ```
//! use mosaicd::capture::Source;
//! use mosaicd::capture::{SyntheticSource, SyntheticSpec};
//! let mut s = SyntheticSource::new(SyntheticSpec { width: 32, height: 16, frames: 2, ..Default::default() });
//! let f = s.next_frame().unwrap().unwrap();
//! assert_eq!((f.width(), f.height(), f.meta.sequence), (32, 16, 0));
//! assert!(s.next_frame().unwrap().is_some());
//! assert!(s.next_frame().unwrap().is_none());
//! ```

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::{CaptureError, Source, SourceKind};
use crate::pool::BufferPool;
use crate::raw::{Cfa, CfaChannel, FrameMeta, Levels, RawFrame, RawPixels};

/// Black level of synthetic frames, as a fraction of full scale (a typical sensor pedestal).
const BLACK_FRACTION: f64 = 1.0 / 16.0;
/// Recorded timestamp of frame 0, ns (arbitrary, non-zero so it is never mistaken for "unset").
const T0_NS: u64 = 1_000_000_000;

/// Parameters of a synthetic stream.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticSpec {
    /// Width (even).
    pub width: usize,
    /// Height (even).
    pub height: usize,
    /// Bit depth (8..=16; 8 uses a u8 container).
    pub bit_depth: u8,
    /// CFA pattern.
    pub cfa: Cfa,
    /// Frames to produce; 0 = endless.
    pub frames: u64,
    /// Frame rate (timestamps; pacing when live).
    pub fps: f64,
    /// Live camera (paced, drop-oldest) instead of a replay.
    pub live: bool,
    /// Frame index at which to produce a frame of the wrong size (fault injection for tests).
    pub wrong_size_at: Option<u64>,
    /// Name reported in metadata.
    pub name: String,
}

impl Default for SyntheticSpec {
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            bit_depth: 12,
            cfa: Cfa::Rggb,
            frames: 0,
            fps: 30.0,
            live: false,
            wrong_size_at: None,
            name: "synthetic".into(),
        }
    }
}

/// The synthetic source.
pub struct SyntheticSource {
    spec: SyntheticSpec,
    next: u64,
    pool: BufferPool<RawPixels>,
    start: Option<Instant>,
    source: Arc<str>,
    /// Pixels of frames `0..cache.len()`, rendered in advance ([`Self::prerender`]).
    cache: Vec<RawPixels>,
}

impl SyntheticSource {
    /// A source with its own buffer pool.
    pub fn new(spec: SyntheticSpec) -> Self {
        Self::with_pool(spec, BufferPool::new(64))
    }

    /// A source drawing pixel buffers from `pool` (the pipeline returns them after use).
    pub fn with_pool(spec: SyntheticSpec, pool: BufferPool<RawPixels>) -> Self {
        let source: Arc<str> = Arc::from(format!("synthetic:{}", spec.name));
        Self {
            spec,
            next: 0,
            pool,
            start: None,
            source,
            cache: Vec::new(),
        }
    }

    /// Render the pixels of frames `0..cycle` now; from then on frame `n` carries the pixels of
    /// frame `n mod cycle`, copied into a pooled buffer, with its own metadata (sequence,
    /// timestamp). `cycle = 0` renders every frame again. The stream's frames are then no longer
    /// a function of `n` alone past `cycle`: for benchmarks, which should not count the
    /// rendering against the pipeline.
    pub fn prerender(&mut self, cycle: u64) -> Result<(), CaptureError> {
        self.cache.clear();
        let mut cache = Vec::new();
        for n in 0..cycle {
            cache.push(self.render(n)?.into_pixels());
        }
        self.cache = cache;
        Ok(())
    }

    /// Full scale and black level of the stream's frames.
    fn max_black(&self) -> (f64, f64) {
        let max = ((1u32 << self.spec.bit_depth) - 1) as f64;
        (max, (max * BLACK_FRACTION).round())
    }

    /// Channel gain of the filter at (x, y).
    fn gain(&self, x: usize, y: usize) -> f64 {
        match self.spec.cfa.channel_at(x, y) {
            CfaChannel::R => 0.55,
            CfaChannel::Gr | CfaChannel::Gb => 1.0,
            CfaChannel::B => 0.4,
        }
    }

    /// Pixel value of frame `n` at (x, y): the definition [`Self::fill_row`] computes fast.
    #[cfg(test)]
    fn value(&self, n: u64, x: usize, y: usize, max: f64, black: f64) -> u16 {
        let gain = self.gain(x, y);
        let shift = 2 * n as usize;
        let u = (x + shift) % 256;
        let bar = if (u / 32).is_multiple_of(2) { 0.8 } else { 0.2 };
        let ramp = (y as f64 / self.spec.height as f64) * 0.2;
        let h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ n.wrapping_mul(0x1656_67B1_9E37_79F9);
        let noise = ((h >> 40) & 0xff) as f64 / 255.0 * 0.02;
        let s = (bar * 0.7 + ramp + noise) * gain;
        (black + s * (max - black)).round().clamp(0.0, max) as u16
    }

    /// Row `y` (`w` pixels) of frame `n`, appended to `out` through `conv`: the values of
    /// [`Self::value`], bit for bit (tested), with the per-row terms hoisted, no division or
    /// filter lookup per pixel, and `round` replaced by `(v + ½)` truncated, which equals it for
    /// every `v` in `[½, 2^51)` (values never go below the black level, ≥ 16). The renderer runs
    /// on the capture thread, so every cycle it spends is taken from the cores whose throughput
    /// `bench pipeline` measures (the per-pixel version cost ≈ 13 % of the CPU there).
    fn fill_row<T>(&self, n: u64, y: usize, w: usize, conv: impl Fn(u16) -> T, out: &mut Vec<T>) {
        let (max, black) = self.max_black();
        let gains = [self.gain(0, y), self.gain(1, y)];
        let shift = (2 * n as usize) & 255;
        let ramp = (y as f64 / self.spec.height as f64) * 0.2;
        let hy = (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F) ^ n.wrapping_mul(0x1656_67B1_9E37_79F9);
        let range = max - black;
        debug_assert!(black >= 0.5, "every value is at least the black level");
        out.extend((0..w).map(|x| {
            let u = (x + shift) & 255;
            let bar = if (u / 32).is_multiple_of(2) { 0.8 } else { 0.2 };
            let h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ hy;
            let noise = ((h >> 40) & 0xff) as f64 / 255.0 * 0.02;
            let s = (bar * 0.7 + ramp + noise) * gains[x & 1];
            // v ≥ black ≥ ½, so (v + ½) truncated is `round(v)`.
            let r = ((black + s * range) + 0.5) as u64;
            conv(r.min(max as u64) as u16)
        }));
    }

    fn render(&mut self, n: u64) -> Result<RawFrame, CaptureError> {
        let (mut w, h) = (self.spec.width, self.spec.height);
        if self.spec.wrong_size_at == Some(n) {
            w += 2;
        }
        let (max, black) = self.max_black();
        let levels = Levels::uniform(black as u16, max as u16);
        let eight = self.spec.bit_depth == 8;
        let mut pixels = self.pool.take(|| {
            if eight {
                RawPixels::U8(Vec::with_capacity(w * h))
            } else {
                RawPixels::U16(Vec::with_capacity(w * h))
            }
        });
        let cached = match self.cache.len() as u64 {
            0 => None,
            _ if self.spec.wrong_size_at == Some(n) => None,
            len => self.cache.get((n % len) as usize),
        };
        match (&mut pixels, cached) {
            (RawPixels::U8(v), Some(RawPixels::U8(c))) => {
                v.clear();
                v.extend_from_slice(c);
            }
            (RawPixels::U16(v), Some(RawPixels::U16(c))) => {
                v.clear();
                v.extend_from_slice(c);
            }
            (RawPixels::U8(v), _) => {
                v.clear();
                for y in 0..h {
                    self.fill_row(n, y, w, |p| p as u8, v);
                }
            }
            (RawPixels::U16(v), _) => {
                v.clear();
                for y in 0..h {
                    self.fill_row(n, y, w, |p| p, v);
                }
            }
        }
        let frame = RawFrame::new(w, h, w, pixels, self.spec.cfa, self.spec.bit_depth, levels)?;
        Ok(frame.with_meta(FrameMeta {
            sequence: n,
            sensor_sequence: Some(n),
            timestamp_ns: T0_NS + (n as f64 * 1e9 / self.spec.fps).round() as u64,
            source: self.source.clone(),
        }))
    }
}

impl Source for SyntheticSource {
    fn next_frame(&mut self) -> Result<Option<RawFrame>, CaptureError> {
        if self.spec.frames != 0 && self.next >= self.spec.frames {
            return Ok(None);
        }
        let n = self.next;
        if self.spec.live {
            let start = *self.start.get_or_insert_with(Instant::now);
            let due = start + Duration::from_secs_f64(n as f64 / self.spec.fps);
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
        }
        self.next += 1;
        let mut f = self.render(n)?;
        if self.spec.live {
            // A live camera stamps frames with the monotonic clock at capture.
            f.meta.timestamp_ns = crate::clock::monotonic_ns();
        }
        Ok(Some(f))
    }

    fn kind(&self) -> SourceKind {
        if self.spec.live {
            SourceKind::Live
        } else {
            SourceKind::Replay
        }
    }

    fn describe(&self) -> String {
        format!(
            "synthetic {}x{} {}-bit {:?} ({})",
            self.spec.width, self.spec.height, self.spec.bit_depth, self.spec.cfa, self.spec.name
        )
    }

    fn is_finished(&self) -> bool {
        self.spec.frames != 0 && self.next >= self.spec.frames
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_a_pure_function_of_the_index() {
        let spec = SyntheticSpec {
            width: 16,
            height: 8,
            frames: 3,
            ..Default::default()
        };
        let a: Vec<_> = {
            let mut s = SyntheticSource::new(spec.clone());
            std::iter::from_fn(|| s.next_frame().unwrap()).collect()
        };
        let b: Vec<_> = {
            let mut s = SyntheticSource::new(spec);
            std::iter::from_fn(|| s.next_frame().unwrap()).collect()
        };
        assert_eq!(a.len(), 3);
        assert_eq!(a, b);
        assert_ne!(a[0].pixels(), a[1].pixels(), "the scene moves");
        assert!(a.iter().all(|f| f.pixels().len() == 16 * 8));
    }

    #[test]
    fn prerendered_frames_repeat_the_cycle_with_their_own_metadata() {
        let spec = SyntheticSpec {
            width: 16,
            height: 8,
            frames: 5,
            wrong_size_at: Some(4),
            ..Default::default()
        };
        let fresh: Vec<_> = {
            let mut s = SyntheticSource::new(spec.clone());
            std::iter::from_fn(|| s.next_frame().unwrap()).collect()
        };
        let mut s = SyntheticSource::new(spec);
        s.prerender(2).unwrap();
        let cyc: Vec<_> = std::iter::from_fn(|| s.next_frame().unwrap()).collect();
        assert_eq!(cyc.len(), 5);
        for (n, f) in cyc.iter().enumerate().take(4) {
            assert_eq!(f.pixels(), fresh[n % 2].pixels(), "frame {n}");
            assert_eq!(f.meta, fresh[n].meta, "frame {n}");
        }
        assert_ne!(cyc[2].pixels(), fresh[2].pixels(), "frame 2 repeats frame 0");
        // Fault injection still renders its frame.
        assert_eq!(cyc[4], fresh[4]);
        assert_eq!(cyc[4].width(), 18);
    }

    #[test]
    fn rows_equal_the_per_pixel_definition() {
        // The bench's whole 1080p 12-bit frame too (2 M values).
        for (bits, cfa, w, h) in [
            (12, Cfa::Rggb, 70, 6),
            (8, Cfa::Gbrg, 34, 4),
            (16, Cfa::Bggr, 300, 4),
            (10, Cfa::Grbg, 18, 2),
            (12, Cfa::Rggb, 1920, 1080),
        ] {
            let src = SyntheticSource::new(SyntheticSpec {
                width: w,
                height: h,
                bit_depth: bits,
                cfa,
                ..Default::default()
            });
            let (max, black) = src.max_black();
            let frames: &[u64] = if h > 100 {
                &[3]
            } else {
                &[0, 1, 7, 127, 128, 1000, u32::MAX as u64]
            };
            for &n in frames {
                for y in 0..h {
                    let mut row = Vec::new();
                    src.fill_row(n, y, w, |p| p, &mut row);
                    let want: Vec<u16> = (0..w).map(|x| src.value(n, x, y, max, black)).collect();
                    assert_eq!(row, want, "{bits}-bit {cfa:?} frame {n} row {y}");
                }
            }
        }
    }

    #[test]
    fn wrong_size_injection() {
        let mut s = SyntheticSource::new(SyntheticSpec {
            width: 16,
            height: 8,
            frames: 2,
            wrong_size_at: Some(1),
            ..Default::default()
        });
        assert_eq!(s.next_frame().unwrap().unwrap().width(), 16);
        assert_eq!(s.next_frame().unwrap().unwrap().width(), 18);
    }
}
