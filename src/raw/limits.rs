//! The one frame-size limit: the largest frame any input may describe, checked before anything
//! is allocated for it.
//!
//! A file, a recording or a driver states a frame's width and height in a few bytes, and a few
//! bytes can claim gigabytes (a zstd chunk of 8.5 KB can hold a 16000x15625 frame; a 233 KB PNG a
//! 16000x15000 one). Every loader therefore checks the size it is told against [`FrameLimits`]
//! before it reads or decodes the pixels:
//!
//! - a side is at most [`MAX_SIDE`] (16384) pixels, and
//! - `width · height` is at most `max_pixels` (config key `limits.max_frame_pixels`, default
//!   [`DEFAULT_MAX_PIXELS`] = 2^26 = 67,108,864, "64 MP": a 8192x8192 frame, or a 100 MP medium-format
//!   raw after raising it).
//!
//! A frame within the limit takes at most `2 · max_pixels` bytes of samples (u16 container), so
//! sizes derived from it (a file, an MCAP record) are bounded too: [`FrameLimits::max_sample_bytes`].
//!
//! The daemon sets the process's limit from its config once at start-up
//! ([`FrameLimits::set_process`]); [`FrameLimits::process`] (also `Default`) returns it, so every
//! loader and source built with default options uses the configured value, and the one-shot
//! commands use the default.
//!
//! ```
//! use mosaicd::raw::{FrameLimits, DEFAULT_MAX_PIXELS};
//! let l = FrameLimits::new(DEFAULT_MAX_PIXELS).unwrap();
//! assert!(l.check(8192, 8192).is_ok());
//! assert!(l.check(16000, 15625).is_err()); // 250 MP
//! assert!(l.check(20000, 2).is_err()); // wider than 16384
//! assert!(FrameLimits::new(0).is_none());
//! ```

use std::sync::atomic::{AtomicU64, Ordering};

/// Largest frame side in pixels.
pub(crate) const MAX_SIDE: usize = 16_384;
/// Default largest frame in pixels (2^26, "64 MP").
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 26;
/// Largest value `limits.max_frame_pixels` accepts: a square frame of [`MAX_SIDE`].
pub(crate) const MAX_MAX_PIXELS: u64 = (MAX_SIDE as u64) * (MAX_SIDE as u64);
/// Bytes one sample takes at most (u16 container).
pub(crate) const MAX_BYTES_PER_SAMPLE: u64 = 2;

/// The process's limit in pixels (0 = not set: the default).
static PROCESS_MAX_PIXELS: AtomicU64 = AtomicU64::new(0);

/// A frame too large for the limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "a {width}x{height} frame exceeds the frame-size limit ({max_side} pixels per side and \
     {max_pixels} pixels in all; config key limits.max_frame_pixels)"
)]
pub struct FrameTooLarge {
    /// Width claimed.
    pub width: u64,
    /// Height claimed.
    pub height: u64,
    /// Pixel limit in force.
    pub max_pixels: u64,
    /// Side limit.
    pub max_side: u64,
}

/// The frame-size limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameLimits {
    max_pixels: u64,
}

impl Default for FrameLimits {
    /// The process's limit ([`FrameLimits::process`]).
    fn default() -> Self {
        Self::process()
    }
}

impl FrameLimits {
    /// The default limit ([`DEFAULT_MAX_PIXELS`]).
    pub const DEFAULT: Self = Self {
        max_pixels: DEFAULT_MAX_PIXELS,
    };

    /// A limit of `max_pixels` (`1..=``MAX_MAX_PIXELS`); `None` outside that range.
    pub fn new(max_pixels: u64) -> Option<Self> {
        (1..=MAX_MAX_PIXELS)
            .contains(&max_pixels)
            .then_some(Self { max_pixels })
    }

    /// The limit in force for this process: the one [`FrameLimits::set_process`] set (the
    /// daemon's `limits.max_frame_pixels`), else [`FrameLimits::DEFAULT`].
    pub fn process() -> Self {
        match PROCESS_MAX_PIXELS.load(Ordering::Relaxed) {
            0 => Self::DEFAULT,
            n => Self { max_pixels: n },
        }
    }

    /// Make this the process's limit (called once at start-up, from the configuration).
    pub fn set_process(self) {
        PROCESS_MAX_PIXELS.store(self.max_pixels, Ordering::Relaxed);
    }

    /// Largest frame in pixels.
    pub fn max_pixels(self) -> u64 {
        self.max_pixels
    }

    /// Largest number of sample bytes a frame within the limit holds (u16 container).
    pub fn max_sample_bytes(self) -> u64 {
        self.max_pixels * MAX_BYTES_PER_SAMPLE
    }

    /// Check a claimed size. Zero sides pass (loaders report empty frames themselves).
    pub fn check(self, width: u64, height: u64) -> Result<(), FrameTooLarge> {
        let side = MAX_SIDE as u64;
        let fits = width <= side
            && height <= side
            && width.checked_mul(height).is_some_and(|n| n <= self.max_pixels);
        if fits {
            Ok(())
        } else {
            Err(FrameTooLarge {
                width,
                height,
                max_pixels: self.max_pixels,
                max_side: side,
            })
        }
    }

    /// [`FrameLimits::check`] for `usize` sizes.
    pub fn check_usize(self, width: usize, height: usize) -> Result<(), FrameTooLarge> {
        self.check(width as u64, height as u64)
    }

    /// The `image` crate's decoder limits for this frame limit: the decoder's allocations
    /// (8 bytes per pixel covers 16-bit RGBA, plus 1 MiB of slack). The sides are checked by the
    /// caller with [`FrameLimits::check`] on the decoder's dimensions, for one error message.
    pub fn image_limits(self) -> image::Limits {
        let mut l = image::Limits::default();
        l.max_alloc = Some(self.max_pixels.saturating_mul(8).saturating_add(1 << 20));
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_refuse_what_is_too_large_and_never_overflow() {
        let l = FrameLimits::DEFAULT;
        assert!(l.check(8192, 8192).is_ok());
        assert!(l.check(16384, 4096).is_ok());
        assert!(l.check(8192, 8193).is_err());
        assert!(l.check(16385, 1).is_err());
        assert!(l.check(u64::MAX, u64::MAX).is_err());
        assert!(l.check(0, 0).is_ok());
        let e = l.check(16000, 15625).unwrap_err();
        assert_eq!(
            (e.width, e.height, e.max_pixels),
            (16000, 15625, DEFAULT_MAX_PIXELS)
        );
        assert!(e.to_string().contains("limits.max_frame_pixels"), "{e}");
        assert_eq!(FrameLimits::new(MAX_MAX_PIXELS + 1), None);
        let big = FrameLimits::new(MAX_MAX_PIXELS).unwrap();
        assert!(big.check(16384, 16384).is_ok());
        assert_eq!(l.max_sample_bytes(), 2 * DEFAULT_MAX_PIXELS);
    }
}
