//! The 8-bit Bayer preview written next to the lossless raw frame so Foxglove can show the stream.
//!
//! The preview keeps the mosaic (Foxglove demosaics `bayer_*8` itself) and is decimated by
//! whole 2x2 tiles: with decimation `d`, preview tile `(tx, ty)` is the source tile at
//! `(2·d·tx, 2·d·ty)`, so the pattern is unchanged and a point `(x, y)` of the frame is at
//! `(x / d, y / d)` in the preview. Values are mapped for display only:
//! `v8 = round(255 · sqrt(clamp((v − black) / (white − black), 0, 1)))`, black taken per 2x2 tile
//! position. The preview is not for analysis; the raw channel is the lossless record.
//!
//! ```
//! use mosaicd::raw::{Cfa, Levels, RawFrame};
//! use mosaicd::record::preview_from_raw;
//! let f = RawFrame::from_u16(4, 4, vec![4095; 16], Cfa::Rggb, 12, Levels::uniform(0, 4095)).unwrap();
//! let p = preview_from_raw(&f, 2).unwrap();
//! assert_eq!((p.width, p.height, p.data.as_slice()), (2, 2, &[255u8; 4][..]));
//! ```

use crate::raw::RawFrame;

/// An 8-bit mosaic preview.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Preview {
    /// Width (even unless the frame is 1 pixel wide).
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Row-major, `width` bytes per row.
    pub data: Vec<u8>,
}

/// Display levels: 4 lookup tables (one per tile position) from raw value to 8 bits.
fn luts(frame: &RawFrame) -> [Vec<u8>; 4] {
    let max = frame.max_value() as usize;
    let white = frame.levels().white as f64;
    std::array::from_fn(|pos| {
        let black = frame.levels().black[pos] as f64;
        let range = (white - black).max(1.0);
        (0..=max)
            .map(|v| {
                let t = ((v as f64 - black) / range).clamp(0.0, 1.0);
                (255.0 * t.sqrt()).round() as u8
            })
            .collect()
    })
}

/// Build the preview of `frame` decimated by `decimation` (≥ 1) whole 2x2 tiles.
/// Returns `None` when the frame is smaller than one decimated tile.
pub fn preview_from_raw(frame: &RawFrame, decimation: usize) -> Option<Preview> {
    let d = decimation.max(1);
    let (w, h) = (frame.width(), frame.height());
    let (pw, ph) = if d == 1 {
        (w, h)
    } else {
        (w / (2 * d) * 2, h / (2 * d) * 2)
    };
    if pw == 0 || ph == 0 {
        return None;
    }
    let lut = luts(frame);
    let max = frame.max_value() as usize;
    let mut data = Vec::with_capacity(pw * ph);
    for py in 0..ph {
        let sy = (py / 2) * 2 * d + (py & 1);
        for px in 0..pw {
            let sx = (px / 2) * 2 * d + (px & 1);
            let pos = (sy & 1) * 2 + (sx & 1);
            // A value above the bit depth (RawFrame allows them) shows as the brightest.
            data.push(lut[pos][(frame.value(sx, sy) as usize).min(max)]);
        }
    }
    Some(Preview {
        width: pw,
        height: ph,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::{Cfa, Levels};

    #[test]
    fn decimation_keeps_tiles_and_phase() {
        // 8x4 frame, value = x + 10*y (12-bit, black 0).
        let px: Vec<u16> = (0..32).map(|i| ((i % 8) + 10 * (i / 8)) as u16).collect();
        let f = RawFrame::from_u16(8, 4, px, Cfa::Grbg, 12, Levels::uniform(0, 4095)).unwrap();
        let p = preview_from_raw(&f, 2).unwrap();
        assert_eq!((p.width, p.height), (4, 2));
        // Preview (2,0) comes from source (4,0); (3,1) from (5,1).
        let lut = |v: f64| (255.0 * (v / 4095.0).sqrt()).round() as u8;
        assert_eq!(p.data[2], lut(4.0));
        assert_eq!(p.data[4 + 3], lut(15.0));
        assert_eq!(p.data[0], 0);
    }

    #[test]
    fn black_is_subtracted_per_position_and_white_saturates() {
        let f = RawFrame::from_u16(
            2,
            2,
            vec![10, 20, 30, 1023],
            Cfa::Rggb,
            10,
            Levels {
                black: [10, 20, 30, 40],
                white: 1023,
            },
        )
        .unwrap();
        let p = preview_from_raw(&f, 1).unwrap();
        assert_eq!(p.data, vec![0, 0, 0, 255]);
        assert!(preview_from_raw(&f, 2).is_none());
    }
}
