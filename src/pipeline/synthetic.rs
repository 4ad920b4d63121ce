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
//! nothing per frame.
//!
//! ```
//! use mosaicd::capture::Source;
//! use mosaicd::pipeline::synthetic::{SyntheticSource, SyntheticSpec};
//! let mut s = SyntheticSource::new(SyntheticSpec { width: 32, height: 16, frames: 2, ..Default::default() });
//! let f = s.next_frame().unwrap().unwrap();
//! assert_eq!((f.width(), f.height(), f.meta.sequence), (32, 16, 0));
//! assert!(s.next_frame().unwrap().is_some());
//! assert!(s.next_frame().unwrap().is_none());
//! ```

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::pool::BufferPool;
use crate::capture::{CaptureError, Source, SourceKind};
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
        }
    }

    /// Pixel value of frame `n` at (x, y).
    fn value(&self, n: u64, x: usize, y: usize, max: f64, black: f64) -> u16 {
        let ch = self.spec.cfa.channel_at(x, y);
        let gain = match ch {
            CfaChannel::R => 0.55,
            CfaChannel::Gr | CfaChannel::Gb => 1.0,
            CfaChannel::B => 0.4,
        };
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

    fn render(&mut self, n: u64) -> Result<RawFrame, CaptureError> {
        let (mut w, h) = (self.spec.width, self.spec.height);
        if self.spec.wrong_size_at == Some(n) {
            w += 2;
        }
        let max = ((1u32 << self.spec.bit_depth) - 1) as f64;
        let black = (max * BLACK_FRACTION).round();
        let levels = Levels::uniform(black as u16, max as u16);
        let eight = self.spec.bit_depth == 8;
        let mut pixels = self.pool.take(|| {
            if eight {
                RawPixels::U8(Vec::with_capacity(w * h))
            } else {
                RawPixels::U16(Vec::with_capacity(w * h))
            }
        });
        match &mut pixels {
            RawPixels::U8(v) => {
                v.clear();
                v.extend((0..w * h).map(|i| self.value(n, i % w, i / w, max, black) as u8));
            }
            RawPixels::U16(v) => {
                v.clear();
                v.extend((0..w * h).map(|i| self.value(n, i % w, i / w, max, black)));
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
            f.meta.timestamp_ns = super::clock::monotonic_ns();
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
