//! Between raw code values and the linear signal, both ways.
//!
//! A raw value `v` with black level `black` (per position in the 2x2 tile) and white level `white`
//! is the linear signal `y = (v − black) / (white − black)` ([`linear_from_raw`]); quantisation is
//! the inverse, `v = round(black + y·(white − black))` clipped to `[0, white]`
//! ([`raw_from_linear_mosaic`]). The reverse ISP quantises its mosaic this way, and the noise model
//! adds its noise on `y`.

use rayon::prelude::*;

use super::IspError;
use crate::image::Image;
use crate::raw::{Cfa, Levels, RawFrame, RawPixels};

/// Rows per parallel strip.
const STRIP_ROWS: usize = 32;

pub(super) fn check_bit_depth(bit_depth: u8) -> Result<(), IspError> {
    if (8..=16).contains(&bit_depth) {
        Ok(())
    } else {
        Err(IspError::Param {
            name: "bit_depth",
            value: bit_depth as f64,
            why: "must be in 8..=16",
        })
    }
}

/// The frame's pixels as linear signal `y = (v − black) / (white − black)` (per tile-position black).
pub fn linear_from_raw(frame: &RawFrame) -> Image<f32> {
    let white = frame.levels().white as f32;
    Image::from_fn(frame.width(), frame.height(), |x, y| {
        let b = frame.black_at(x, y) as f32;
        (frame.value(x, y) as f32 - b) / (white - b)
    })
}

/// Quantise a linear mosaic (`0` = black, `1` = white) into a raw frame:
/// `v = round(black + y·(white − black))`, clipped to `[0, white]`.
pub fn raw_from_linear_mosaic(
    mosaic: &Image<f32>,
    cfa: Cfa,
    bit_depth: u8,
    levels: Levels,
) -> Result<RawFrame, IspError> {
    check_bit_depth(bit_depth)?;
    let (w, h) = mosaic.dimensions();
    if w == 0 || h == 0 {
        return Err(IspError::Empty { width: w, height: h });
    }
    let white = levels.white as f32;
    let quant = |x: usize, y: usize, v: f32| -> u16 {
        let b = levels.black[(y & 1) * 2 + (x & 1)] as f32;
        let q = (b + v * (white - b)).round();
        if q.is_nan() {
            0
        } else {
            q.clamp(0.0, white) as u16
        }
    };
    let chunk = w * STRIP_ROWS;
    let pixels = if bit_depth == 8 {
        let mut out = vec![0u8; w * h];
        out.par_chunks_mut(chunk)
            .zip(mosaic.as_slice().par_chunks(chunk))
            .enumerate()
            .for_each(|(s, (o, m))| {
                for (i, (d, v)) in o.iter_mut().zip(m).enumerate() {
                    *d = quant(i % w, s * STRIP_ROWS + i / w, *v) as u8;
                }
            });
        RawPixels::U8(out)
    } else {
        let mut out = vec![0u16; w * h];
        out.par_chunks_mut(chunk)
            .zip(mosaic.as_slice().par_chunks(chunk))
            .enumerate()
            .for_each(|(s, (o, m))| {
                for (i, (d, v)) in o.iter_mut().zip(m).enumerate() {
                    *d = quant(i % w, s * STRIP_ROWS + i / w, *v);
                }
            });
        RawPixels::U16(out)
    };
    Ok(RawFrame::new(w, h, w, pixels, cfa, bit_depth, levels)?)
}
