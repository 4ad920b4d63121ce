//! [`RawFrame`]: a Bayer mosaic with everything needed to interpret it.
//!
//! Pixels are linear sensor values in a `u8` or `u16` container, row-major with a row stride, and
//! travel together with their [`Cfa`] pattern, bit depth, black level (one per 2x2 tile position,
//! as many sensors have) and white level, optional white-balance gains from the file's metadata,
//! and capture metadata ([`FrameMeta`]).
//!
//! ```
//! use mosaicd::raw::{Cfa, Levels, RawFrame};
//! let px: Vec<u16> = (0..16).collect();
//! let f = RawFrame::from_u16(4, 4, px, Cfa::Rggb, 12, Levels::uniform(0, 4095)).unwrap();
//! let c = f.crop(1, 1, 2, 2).unwrap();
//! assert_eq!(c.cfa(), Cfa::Bggr); // cropped at an odd offset: re-phased
//! assert_eq!(c.value(0, 0), 5);
//! ```

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::{Cfa, RawError};
use crate::image::ImageView;

/// Black level per 2x2 tile position and one white level, in raw units.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Levels {
    /// Black level at tile position `[(y & 1) * 2 + (x & 1)]`.
    pub black: [u16; 4],
    /// Saturation (white) level.
    pub white: u16,
}

impl Levels {
    /// The same black level at every tile position.
    pub fn uniform(black: u16, white: u16) -> Self {
        Self {
            black: [black; 4],
            white,
        }
    }

    /// Levels after cropping at (dx, dy): tile positions move with the crop.
    pub fn shifted(&self, dx: usize, dy: usize) -> Self {
        let mut black = [0; 4];
        for (i, b) in black.iter_mut().enumerate() {
            let (x, y) = (i & 1, i >> 1);
            *b = self.black[((y + dy) & 1) * 2 + ((x + dx) & 1)];
        }
        Self {
            black,
            white: self.white,
        }
    }

    /// Largest black level.
    pub fn max_black(&self) -> u16 {
        *self.black.iter().max().unwrap_or(&0)
    }
}

/// Capture metadata that travels with a frame.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FrameMeta {
    /// Our sequence number, dense from 0 per source.
    pub sequence: u64,
    /// The sensor's / driver's own sequence number when it has one (V4L2 `sequence`).
    pub sensor_sequence: Option<u64>,
    /// Capture time in nanoseconds (source clock: monotonic for V4L2, recorded for replay).
    pub timestamp_ns: u64,
    /// Where the frame came from (device path, file name, recording channel).
    pub source: Arc<str>,
}

/// The pixel buffer of a frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RawPixels {
    /// 8-bit container.
    U8(Vec<u8>),
    /// 16-bit container (any bit depth from 8 to 16, LSB-aligned).
    U16(Vec<u16>),
}

impl RawPixels {
    /// Number of stored pixels.
    pub fn len(&self) -> usize {
        match self {
            RawPixels::U8(v) => v.len(),
            RawPixels::U16(v) => v.len(),
        }
    }

    /// True when no pixels are stored.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A borrowed view of a frame's pixels in its container type.
#[derive(Debug, Clone, Copy)]
pub enum RawView<'a> {
    /// 8-bit container.
    U8(ImageView<'a, u8>),
    /// 16-bit container.
    U16(ImageView<'a, u16>),
}

impl RawView<'_> {
    /// Width in pixels.
    pub fn width(&self) -> usize {
        match self {
            RawView::U8(v) => v.width(),
            RawView::U16(v) => v.width(),
        }
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        match self {
            RawView::U8(v) => v.height(),
            RawView::U16(v) => v.height(),
        }
    }
}

/// A raw Bayer frame: pixels, pattern, bit depth, levels and metadata.
#[derive(Debug, Clone, PartialEq)]
pub struct RawFrame {
    width: usize,
    height: usize,
    stride: usize,
    pixels: RawPixels,
    cfa: Cfa,
    bit_depth: u8,
    levels: Levels,
    /// White-balance gains (R, G, B) from the file's metadata, when it has them.
    pub wb_gains: Option<[f32; 3]>,
    /// Capture metadata.
    pub meta: FrameMeta,
}

impl RawFrame {
    /// Build a frame, checking every invariant.
    ///
    /// `stride` is in pixels. Bit depth must be 8 for a `u8` container and 8..=16 for `u16`;
    /// black levels must be below the white level, which must fit in the bit depth.
    pub fn new(
        width: usize,
        height: usize,
        stride: usize,
        pixels: RawPixels,
        cfa: Cfa,
        bit_depth: u8,
        levels: Levels,
    ) -> Result<Self, RawError> {
        if width == 0 || height == 0 {
            return Err(RawError::EmptyFrame { width, height });
        }
        if stride < width {
            return Err(RawError::Stride { stride, width });
        }
        let ok_depth = match pixels {
            RawPixels::U8(_) => bit_depth == 8,
            RawPixels::U16(_) => (8..=16).contains(&bit_depth),
        };
        if !ok_depth {
            return Err(RawError::BitDepth {
                bit_depth,
                container_bits: if matches!(pixels, RawPixels::U8(_)) { 8 } else { 16 },
            });
        }
        let max = ((1u32 << bit_depth) - 1) as u16;
        if levels.white > max || levels.max_black() >= levels.white {
            return Err(RawError::Levels {
                black: levels.black,
                white: levels.white,
                max,
            });
        }
        // Checked: sizes from a file or a message must not wrap past this test.
        let needed = stride
            .checked_mul(height - 1)
            .and_then(|v| v.checked_add(width))
            .unwrap_or(usize::MAX);
        if pixels.len() < needed {
            return Err(RawError::BufferSize {
                len: pixels.len(),
                needed,
                width,
                height,
                stride,
            });
        }
        Ok(Self {
            width,
            height,
            stride,
            pixels,
            cfa,
            bit_depth,
            levels,
            wb_gains: None,
            meta: FrameMeta::default(),
        })
    }

    /// A contiguous 16-bit frame.
    pub fn from_u16(
        width: usize,
        height: usize,
        data: Vec<u16>,
        cfa: Cfa,
        bit_depth: u8,
        levels: Levels,
    ) -> Result<Self, RawError> {
        Self::new(width, height, width, RawPixels::U16(data), cfa, bit_depth, levels)
    }

    /// A contiguous 8-bit frame.
    pub fn from_u8(
        width: usize,
        height: usize,
        data: Vec<u8>,
        cfa: Cfa,
        levels: Levels,
    ) -> Result<Self, RawError> {
        Self::new(width, height, width, RawPixels::U8(data), cfa, 8, levels)
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// Row stride in pixels.
    #[inline]
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// The CFA pattern at (0, 0).
    #[inline]
    pub fn cfa(&self) -> Cfa {
        self.cfa
    }

    /// Significant bits per pixel.
    #[inline]
    pub fn bit_depth(&self) -> u8 {
        self.bit_depth
    }

    /// Black and white levels.
    #[inline]
    pub fn levels(&self) -> &Levels {
        &self.levels
    }

    /// Largest value the bit depth can hold.
    pub fn max_value(&self) -> u16 {
        ((1u32 << self.bit_depth) - 1) as u16
    }

    /// The pixel buffer.
    pub fn pixels(&self) -> &RawPixels {
        &self.pixels
    }

    /// Give up the pixel buffer (for pooling).
    pub fn into_pixels(self) -> RawPixels {
        self.pixels
    }

    /// A view of the pixels in their container type.
    pub fn view(&self) -> RawView<'_> {
        match &self.pixels {
            RawPixels::U8(v) => RawView::U8(
                ImageView::new(v, self.width, self.height, self.stride).expect("invariant checked in new"),
            ),
            RawPixels::U16(v) => RawView::U16(
                ImageView::new(v, self.width, self.height, self.stride).expect("invariant checked in new"),
            ),
        }
    }

    /// The raw value at (x, y), widened to u16.
    #[inline]
    pub fn value(&self, x: usize, y: usize) -> u16 {
        let i = y * self.stride + x;
        match &self.pixels {
            RawPixels::U8(v) => v[i] as u16,
            RawPixels::U16(v) => v[i],
        }
    }

    /// Black level at (x, y).
    #[inline]
    pub fn black_at(&self, x: usize, y: usize) -> u16 {
        self.levels.black[(y & 1) * 2 + (x & 1)]
    }

    /// Copy out a `w` x `h` crop at (x, y). The pattern and black levels are re-phased when the
    /// offset is odd; metadata and gains are kept.
    pub fn crop(&self, x: usize, y: usize, w: usize, h: usize) -> Result<RawFrame, RawError> {
        if w == 0 || h == 0 || x + w > self.width || y + h > self.height {
            return Err(RawError::Crop {
                x,
                y,
                w,
                h,
                width: self.width,
                height: self.height,
            });
        }
        let pixels = match self.view() {
            RawView::U8(v) => RawPixels::U8(v.crop(x, y, w, h).expect("checked").to_image().into_vec()),
            RawView::U16(v) => RawPixels::U16(v.crop(x, y, w, h).expect("checked").to_image().into_vec()),
        };
        let mut out = RawFrame::new(
            w,
            h,
            w,
            pixels,
            self.cfa.shifted(x, y),
            self.bit_depth,
            self.levels.shifted(x, y),
        )?;
        out.wb_gains = self.wb_gains;
        out.meta = self.meta.clone();
        Ok(out)
    }

    /// Builder-style: attach metadata.
    pub fn with_meta(mut self, meta: FrameMeta) -> Self {
        self.meta = meta;
        self
    }

    /// Builder-style: attach white-balance gains (R, G, B).
    pub fn with_wb_gains(mut self, gains: [f32; 3]) -> Self {
        self.wb_gains = Some(gains);
        self
    }

    /// The frame as a sensor `shift` bits deeper would deliver it (e.g. a 10-bit frame in a
    /// 12-bit container, `shift = 2`): every sample and black level multiplied by `2^shift`, the
    /// white level mapped to the top of the values its own level stands for,
    /// `white·2^shift + 2^shift − 1` (a full-scale white stays full scale: 1023 → 4095). The
    /// result is a contiguous `u16` frame of depth `bit_depth + shift` with the same pattern,
    /// gains and metadata. Refused when the depth would exceed 16 bits.
    pub fn promoted(&self, shift: u8) -> Result<RawFrame, RawError> {
        let bit_depth = self.bit_depth.saturating_add(shift);
        if bit_depth > 16 {
            return Err(RawError::BitDepth {
                bit_depth,
                container_bits: 16,
            });
        }
        let data: Vec<u16> = self.to_u16_vec().into_iter().map(|v| v << shift).collect();
        let levels = Levels {
            black: self.levels.black.map(|b| b << shift),
            white: (self.levels.white << shift) | ((1u16 << shift) - 1),
        };
        let mut f = RawFrame::from_u16(self.width, self.height, data, self.cfa, bit_depth, levels)?;
        f.wb_gains = self.wb_gains;
        f.meta = self.meta.clone();
        Ok(f)
    }

    /// Widen to a contiguous `u16` buffer (copy).
    pub fn to_u16_vec(&self) -> Vec<u16> {
        let mut out = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            for x in 0..self.width {
                out.push(self.value(x, y));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(cfa: Cfa) -> RawFrame {
        let px: Vec<u16> = (0..36).collect();
        RawFrame::from_u16(
            6,
            6,
            px,
            cfa,
            12,
            Levels {
                black: [1, 2, 3, 4],
                white: 4095,
            },
        )
        .unwrap()
    }

    #[test]
    fn crop_rephases_pattern_and_levels_for_all_patterns() {
        for cfa in Cfa::ALL {
            let f = frame(cfa);
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1), (3, 2)] {
                let c = f.crop(dx, dy, 2, 2).unwrap();
                for y in 0..2 {
                    for x in 0..2 {
                        assert_eq!(c.cfa().channel_at(x, y), cfa.channel_at(x + dx, y + dy));
                        assert_eq!(c.black_at(x, y), f.black_at(x + dx, y + dy));
                        assert_eq!(c.value(x, y), f.value(x + dx, y + dy));
                    }
                }
            }
        }
    }

    #[test]
    fn rejects_bad_frames() {
        let lv = Levels::uniform(0, 255);
        assert!(matches!(
            RawFrame::from_u8(0, 4, vec![], Cfa::Rggb, lv),
            Err(RawError::EmptyFrame { .. })
        ));
        assert!(matches!(
            RawFrame::from_u8(4, 4, vec![0; 15], Cfa::Rggb, lv),
            Err(RawError::BufferSize { .. })
        ));
        assert!(matches!(
            RawFrame::from_u16(2, 2, vec![0; 4], Cfa::Rggb, 17, lv),
            Err(RawError::BitDepth { .. })
        ));
        assert!(matches!(
            RawFrame::from_u16(2, 2, vec![0; 4], Cfa::Rggb, 10, Levels::uniform(0, 4095)),
            Err(RawError::Levels { .. })
        ));
        assert!(matches!(
            RawFrame::from_u8(2, 2, vec![0; 4], Cfa::Rggb, Levels::uniform(255, 255)),
            Err(RawError::Levels { .. })
        ));
        assert!(frame(Cfa::Rggb).crop(5, 5, 2, 2).is_err());
    }

    #[test]
    fn strided_frame_reads_through_stride() {
        let data: Vec<u8> = vec![1, 2, 99, 3, 4, 99];
        let f = RawFrame::new(
            2,
            2,
            3,
            RawPixels::U8(data),
            Cfa::Gbrg,
            8,
            Levels::uniform(0, 255),
        )
        .unwrap();
        assert_eq!(f.to_u16_vec(), vec![1, 2, 3, 4]);
    }

    #[test]
    fn promotion_scales_samples_and_levels() {
        let f = RawFrame::from_u16(
            2,
            2,
            vec![0, 1, 512, 1020],
            Cfa::Grbg,
            10,
            Levels::uniform(16, 1023),
        )
        .unwrap()
        .with_wb_gains([2.0, 1.0, 1.5]);
        let p = f.promoted(2).unwrap();
        assert_eq!(p.bit_depth(), 12);
        assert_eq!(p.to_u16_vec(), vec![0, 4, 2048, 4080]);
        assert_eq!(p.levels(), &Levels::uniform(64, 4095));
        assert_eq!((p.cfa(), p.wb_gains), (Cfa::Grbg, Some([2.0, 1.0, 1.5])));
        assert_eq!(f.promoted(0).unwrap(), f);
        assert!(matches!(
            f.promoted(7),
            Err(RawError::BitDepth { bit_depth: 17, .. })
        ));
    }
}
