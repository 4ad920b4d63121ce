//! Normalisation of raw values to the working range, in one pass.
//!
//! Every feature in mosaicd works on **linear** values in `[0, 1]`: black level removed, scaled by
//! the white level, optionally white-balanced per colour and optionally compressed (gamma or
//! square root). [`NormaliseOptions`] is validated once into a [`NormaliseSpec`];
//! [`normalise_into`] then writes an `Image<f32>` (parallel over row strips) and
//! [`f32_from_raw`] allocates it. [`u16_from_raw`] is the daemon's integer path: black-subtracted,
//! clamped, optionally white-balanced in fixed point, still in raw units.
//!
//! ```
//! use mosaicd::raw::{Cfa, Levels, RawFrame};
//! use mosaicd::raw::{f32_from_raw, Compression, Gains, NormaliseOptions};
//! let f = RawFrame::from_u16(2, 2, vec![100, 600, 1100, 50], Cfa::Rggb, 12, Levels::uniform(100, 1100)).unwrap();
//! let spec = NormaliseOptions { gains: Gains::None, compression: Compression::None }.build().unwrap();
//! let img = f32_from_raw(&f, &spec).unwrap();
//! assert_eq!(img.as_slice(), &[0.0, 0.5, 1.0, 0.0]); // 50 is below black: clamped to 0
//! ```
//!
//! ## Math
//! For a pixel at (x, y) with raw value `v`, tile position `p = (y & 1) * 2 + (x & 1)`, colour `c`:
//!
//! ```text
//! l = clamp((v - black[p]) / (white - black[p]), 0, 1)     linear, black removed
//! w = min(l * gain[c], 1)                                   white balance (gain[G] = 1 usually)
//! out = w                 (Compression::None)
//!     = w ^ exponent      (Compression::Gamma, e.g. 1/2.2: the paper's gamma for low-contrast raw)
//!     = sqrt(w)           (Compression::Sqrt, what OpenCV's HOG does with gammaCorrection)
//! ```
//!
//! Grey-world gains are `mean(G) / mean(R)` and `mean(G) / mean(B)` over the black-subtracted,
//! linear values of pixels below the white level (saturated pixels say nothing about the light's
//! colour). Gains from the file are the camera's white balance as the loader found it
//! (`RawFrame::wb_gains`, normalised to G = 1).
//!
//! ## Which gains by default
//! The paper's argument (colour differences vary slowly, so the gradient of any one channel
//! approximates the scene gradient) does not cover raw R and B being much darker than G before
//! white balance. We measured (tests/raw_wb_gains.rs, table in docs/raw.md) the parity of the
//! mosaic gradient with the gradient of a demosaiced, white-balanced BT.601 grey image on the 8
//! real raw frames we have. White balance does **not** improve parity on average: grey-world gains
//! win narrowly on 5 of 8 frames but lose clearly on 3 (mean PSNR 35.97 vs 36.20 dB, mean GMSD
//! 0.0514 vs 0.0455, orientation error 12.2° vs 12.1°), and the sensor's own tuned gains lose on
//! 4 of 6 frames (they amplify the noise and quantisation of the dark R and B pixels, and colour
//! edges). So the default is [`Gains::None`]; the other modes are there for callers that want
//! white-balanced values (display, colour features).
//!
//! ## Deviations
//! Clamping after the gains clips highlights to white (a demosaicing ISP would keep them as
//! coloured highlights until its tone curve); gradients are not affected below white.
//! `Compression::Sqrt` is applied to `[0, 1]` values, OpenCV applies it to `[0, 255]` values, which
//! differs by the constant factor `sqrt(255)`.
//!
//! References: Zhou, Zhang, Gao, Lou, "Gradient-based Feature Extraction From Raw Bayer Pattern
//! Images" §III (gamma compression of raw); Dalal & Triggs 2005 and OpenCV `hog.cpp` (sqrt gamma);
//! Buchsbaum 1980 (grey-world assumption).

use std::str::FromStr;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{Colour, RawError, RawFrame, RawPixels, RawView};
use crate::image::Image;

/// Rows per parallel work item (a strip of 16 rows of a 4K frame is ~250 KB of f32 output).
pub(crate) const STRIP_ROWS: usize = 16;

/// Largest accepted gain (fixed-point integer path holds gains below this in Q4.12).
pub(crate) const MAX_GAIN: f32 = 16.0;

/// Fraction bits of the fixed-point gains in [`u16_from_raw`] (Q4.12).
pub(crate) const GAIN_FRAC_BITS: u32 = 12;

/// Where per-colour gains come from.
///
/// In config files (serde, kebab-case): `"none"`, `"from-file"`, `"grey-world"`, `"auto"` or
/// `{ fixed = [r, g, b] }`. On the command line (`FromStr`): `none`, `file`,
/// `grey-world`, `auto` or `R,G,B`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Gains {
    /// No white balance: R, G, B as the sensor saw them.
    None,
    /// The gains in the file's metadata (`RawFrame::wb_gains`); an error when it has none.
    FromFile,
    /// Fixed gains `[r, g, b]`, e.g. from the camera's configuration.
    Fixed([f32; 3]),
    /// Grey-world estimate from the frame itself.
    GreyWorld,
    /// The file's gains when it has them, otherwise grey world.
    Auto,
}

/// Tone compression applied after white balance.
///
/// In config files: `"none"`, `"sqrt"` or `{ gamma = 0.4545 }`; on the command line: `none`,
/// `sqrt` or `gamma:EXPONENT`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Compression {
    /// Linear output.
    None,
    /// `out = w ^ exponent` (exponent in (0, 4]; 1/2.2 is the usual display gamma).
    Gamma(f32),
    /// `out = sqrt(w)` (OpenCV HOG's `gammaCorrection`).
    Sqrt,
}

/// Normalisation options, validated by [`NormaliseOptions::build`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NormaliseOptions {
    /// White-balance gains.
    pub gains: Gains,
    /// Tone compression.
    pub compression: Compression,
}

impl Default for NormaliseOptions {
    /// The measured default: [`Gains::None`], no compression.
    fn default() -> Self {
        Self {
            gains: Gains::None,
            compression: Compression::None,
        }
    }
}

/// Error parsing a [`Gains`] or [`Compression`] from text.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot parse {text:?}: expected {expected}")]
pub struct ParseOptionError {
    /// The text given.
    pub text: String,
    /// What was expected.
    pub expected: &'static str,
}

impl FromStr for Gains {
    type Err = ParseOptionError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = || ParseOptionError {
            text: s.to_string(),
            expected: "none, file, grey-world, auto or R,G,B",
        };
        match s.trim().to_ascii_lowercase().as_str() {
            "none" => Ok(Gains::None),
            "file" | "from-file" => Ok(Gains::FromFile),
            "grey-world" | "gray-world" => Ok(Gains::GreyWorld),
            "auto" => Ok(Gains::Auto),
            other => {
                let v: Vec<f32> = other
                    .split(',')
                    .map(|t| t.trim().parse::<f32>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| err())?;
                match v.as_slice() {
                    [r, g, b] => Ok(Gains::Fixed([*r, *g, *b])),
                    _ => Err(err()),
                }
            }
        }
    }
}

impl FromStr for Compression {
    type Err = ParseOptionError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = || ParseOptionError {
            text: s.to_string(),
            expected: "none, sqrt or gamma:EXPONENT",
        };
        match s.trim().to_ascii_lowercase().as_str() {
            "none" => Ok(Compression::None),
            "sqrt" => Ok(Compression::Sqrt),
            other => other
                .strip_prefix("gamma:")
                .and_then(|e| e.trim().parse::<f32>().ok())
                .map(Compression::Gamma)
                .ok_or_else(err),
        }
    }
}

/// Largest accepted gamma exponent.
const MAX_GAMMA_EXPONENT: f32 = 4.0;

/// Validated normalisation parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormaliseSpec {
    gains: Gains,
    compression: Compression,
}

fn check_gains(g: &[f32; 3]) -> Result<(), RawError> {
    for (name, &v) in ["gain_r", "gain_g", "gain_b"].iter().zip(g) {
        if !(v.is_finite() && v > 0.0 && v < MAX_GAIN) {
            return Err(RawError::Param {
                name,
                value: v as f64,
                why: "gains must be finite, > 0 and < 16",
            });
        }
    }
    Ok(())
}

impl NormaliseOptions {
    /// Validate into a spec.
    pub fn build(self) -> Result<NormaliseSpec, RawError> {
        if let Gains::Fixed(g) = &self.gains {
            check_gains(g)?;
        }
        if let Compression::Gamma(e) = self.compression {
            if !(e.is_finite() && e > 0.0 && e <= MAX_GAMMA_EXPONENT) {
                return Err(RawError::Param {
                    name: "gamma",
                    value: e as f64,
                    why: "the gamma exponent must be in (0, 4]",
                });
            }
        }
        Ok(NormaliseSpec {
            gains: self.gains,
            compression: self.compression,
        })
    }
}

impl NormaliseSpec {
    /// The gains mode.
    pub fn gains(&self) -> Gains {
        self.gains
    }

    /// The compression.
    pub fn compression(&self) -> Compression {
        self.compression
    }

    /// The `[r, g, b]` gains this spec applies to `frame` (`[1, 1, 1]` for [`Gains::None`]).
    pub fn gains_for(&self, frame: &RawFrame) -> Result<[f32; 3], RawError> {
        let g = match self.gains {
            Gains::None => [1.0; 3],
            Gains::Fixed(g) => g,
            Gains::FromFile => frame.wb_gains.ok_or_else(|| RawError::NoFileGains {
                origin: frame.meta.source.to_string(),
            })?,
            Gains::GreyWorld => grey_world_gains(frame),
            // gains the file has but that are out of range fall back to grey world too
            Gains::Auto => match frame.wb_gains {
                Some(g) if check_gains(&g).is_ok() => g,
                _ => grey_world_gains(frame),
            },
        };
        check_gains(&g)?;
        Ok(g)
    }
}

fn colour_index(c: Colour) -> usize {
    match c {
        Colour::Red => 0,
        Colour::Green => 1,
        Colour::Blue => 2,
    }
}

/// Grey-world gains `[mean(G)/mean(R), 1, mean(G)/mean(B)]` over black-subtracted linear values
/// of pixels below white. A colour with no usable pixel (or a zero mean) gets gain 1.
///
/// Parallel over row strips with exact integer sums per tile position, so the gains are the same
/// for any thread count (the daemon computes them for every frame with `compute.wb_gains = "auto"`).
pub fn grey_world_gains(frame: &RawFrame) -> [f32; 3] {
    let lv = *frame.levels();
    let (w, h) = (frame.width(), frame.height());
    let view = frame.view();
    // per tile position p = (y & 1) * 2 + (x & 1): Σ (v − black) and the count, for v < white
    let row_sums = |y: usize| -> [(u64, u64); 4] {
        let blacks = [lv.black[(y & 1) * 2], lv.black[(y & 1) * 2 + 1]];
        let [even, odd] = match view {
            RawView::U8(img) => row_tile_sums(&img.row(y)[..w], lv.white, blacks),
            RawView::U16(img) => row_tile_sums(&img.row(y)[..w], lv.white, blacks),
        };
        let mut acc = [(0u64, 0u64); 4];
        acc[(y & 1) * 2] = even;
        acc[(y & 1) * 2 + 1] = odd;
        acc
    };
    let tiles = (0..h)
        .into_par_iter()
        .with_min_len(STRIP_ROWS)
        .map(row_sums)
        .reduce(
            || [(0u64, 0u64); 4],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    x.0 += y.0;
                    x.1 += y.1;
                }
                a
            },
        );
    let mut sum = [0f64; 3];
    let mut count = [0u64; 3];
    for (p, &(s, n)) in tiles.iter().enumerate() {
        let c = colour_index(frame.cfa().colour_at(p & 1, p >> 1));
        let range = lv.white.saturating_sub(lv.black[p]).max(1) as f64;
        sum[c] += s as f64 / range;
        count[c] += n;
    }
    let mean = |c: usize| {
        if count[c] == 0 {
            0.0
        } else {
            sum[c] / count[c] as f64
        }
    };
    let g = mean(1);
    let gain = |c: usize| {
        let m = mean(c);
        if m > 0.0 && g > 0.0 {
            ((g / m) as f32).min(MAX_GAIN * 0.999)
        } else {
            1.0
        }
    };
    [gain(0), 1.0, gain(2)]
}

/// Σ (v − black) and the count of the values below `white` of one row, for its even and its odd
/// columns (`blacks` in that order). Sums run branch-free in `u32` lanes of 16 columns, which the
/// compiler vectorises, emptied into `u64` every 1024 chunks (a lane then holds at most 1024
/// values below 65 536: no overflow). Integer sums are exact, so these equal a plain loop's.
fn row_tile_sums<T: Copy + Into<u16>>(row: &[T], white: u16, blacks: [u16; 2]) -> [(u64, u64); 2] {
    const LANES: usize = 16;
    const CHUNKS: usize = 1024;
    let mut out = [(0u64, 0u64); 2];
    let add = |vals: &[T], sum: &mut [u32; LANES], count: &mut [u32; LANES]| {
        for (l, &v) in vals.iter().enumerate() {
            let v: u16 = v.into();
            let ok = u32::from(v < white);
            sum[l] += ok * u32::from(v.saturating_sub(blacks[l & 1]));
            count[l] += ok;
        }
    };
    for block in row.chunks(LANES * CHUNKS) {
        let mut sum = [0u32; LANES];
        let mut count = [0u32; LANES];
        let mut chunks = block.chunks_exact(LANES);
        for c in &mut chunks {
            add(c, &mut sum, &mut count);
        }
        // The remainder starts at a multiple of 16, so lane parity is still column parity.
        add(chunks.remainder(), &mut sum, &mut count);
        for (l, (s, c)) in sum.iter().zip(&count).enumerate() {
            out[l & 1].0 += u64::from(*s);
            out[l & 1].1 += u64::from(*c);
        }
    }
    out
}

/// Per tile position: black level, `1 / (white - black)` and the gain of its colour.
#[derive(Debug, Clone, Copy)]
struct TileParams {
    black: [f32; 4],
    inv_range: [f32; 4],
    gain: [f32; 4],
    compression: Compression,
}

impl TileParams {
    fn new(frame: &RawFrame, gains: &[f32; 3], compression: Compression) -> Self {
        let lv = frame.levels();
        let mut t = TileParams {
            black: [0.0; 4],
            inv_range: [0.0; 4],
            gain: [1.0; 4],
            compression,
        };
        for p in 0..4 {
            let (x, y) = (p & 1, p >> 1);
            t.black[p] = lv.black[p] as f32;
            t.inv_range[p] = 1.0 / (lv.white - lv.black[p]) as f32;
            t.gain[p] = gains[colour_index(frame.cfa().colour_at(x, y))];
        }
        t
    }

    /// The normalised value of raw value `v` at tile position `p` (the formula of the module docs).
    #[inline]
    fn value(&self, p: usize, v: f32) -> f32 {
        let l = ((v - self.black[p]) * self.inv_range[p]).clamp(0.0, 1.0);
        compress((l * self.gain[p]).min(1.0), self.compression)
    }
}

#[inline]
fn compress(w: f32, c: Compression) -> f32 {
    match c {
        Compression::None => w,
        Compression::Gamma(e) => w.powf(e),
        Compression::Sqrt => w.sqrt(),
    }
}

/// How rows are mapped: the formula per pixel, or (when compression makes the formula costly) a
/// lookup table per tile position over every raw value `0..=max_value`. Both give identical
/// results: the table holds the formula's values, and values above `max_value` (which are above
/// white) map like `max_value`.
enum Mapper {
    Formula(TileParams),
    Table { lut: Vec<f32>, len: usize },
}

impl Mapper {
    fn new(frame: &RawFrame, params: TileParams, use_table: bool) -> Self {
        if !use_table {
            return Mapper::Formula(params);
        }
        let len = frame.max_value() as usize + 1;
        let mut lut = Vec::with_capacity(4 * len);
        for p in 0..4 {
            lut.extend((0..len).map(|v| params.value(p, v as f32)));
        }
        Mapper::Table { lut, len }
    }
}

/// Normalise rows `y0..` of `frame` into `out` (whole rows of width `frame.width()`).
fn normalise_rows(frame: &RawFrame, mapper: &Mapper, y0: usize, out: &mut [f32]) {
    let w = frame.width();
    let stride = frame.stride();
    for (dy, row_out) in out.chunks_exact_mut(w).enumerate() {
        let y = y0 + dy;
        let pb = (y & 1) * 2;
        let start = y * stride;
        macro_rules! run {
            ($row:expr) => {
                match mapper {
                    Mapper::Formula(t) => {
                        for (x, (o, &v)) in row_out.iter_mut().zip($row).enumerate() {
                            *o = t.value(pb + (x & 1), v as f32);
                        }
                    }
                    Mapper::Table { lut, len } => {
                        let last = len - 1;
                        let tabs = [
                            &lut[pb * len..(pb + 1) * len],
                            &lut[(pb + 1) * len..(pb + 2) * len],
                        ];
                        for (x, (o, &v)) in row_out.iter_mut().zip($row).enumerate() {
                            *o = tabs[x & 1][(v as usize).min(last)];
                        }
                    }
                }
            };
        }
        match frame.pixels() {
            RawPixels::U8(v) => run!(&v[start..start + w]),
            RawPixels::U16(v) => run!(&v[start..start + w]),
        }
    }
}

fn prepare(frame: &RawFrame, spec: &NormaliseSpec, dst: &mut Image<f32>) -> Result<Mapper, RawError> {
    let gains = spec.gains_for(frame)?;
    dst.reshape(frame.width(), frame.height());
    let params = TileParams::new(frame, &gains, spec.compression);
    // A table pays off when compression costs more than a lookup and the frame has more pixels
    // than the table has entries.
    let table_len = 4 * (frame.max_value() as usize + 1);
    let use_table = spec.compression != Compression::None && frame.width() * frame.height() >= table_len;
    Ok(Mapper::new(frame, params, use_table))
}

/// Normalise `frame` into `dst` (reshaped to the frame's size), in parallel over strips of
/// `STRIP_ROWS` rows on the current rayon pool.
pub fn normalise_into(frame: &RawFrame, spec: &NormaliseSpec, dst: &mut Image<f32>) -> Result<(), RawError> {
    let mapper = prepare(frame, spec, dst)?;
    let w = frame.width();
    dst.as_mut_slice()
        .par_chunks_mut(w * STRIP_ROWS)
        .enumerate()
        .for_each(|(i, strip)| normalise_rows(frame, &mapper, i * STRIP_ROWS, strip));
    Ok(())
}

/// [`normalise_into`] on the calling thread only (the reference for the parallel path).
#[cfg(test)]
pub(crate) fn normalise_into_serial(
    frame: &RawFrame,
    spec: &NormaliseSpec,
    dst: &mut Image<f32>,
) -> Result<(), RawError> {
    let mapper = prepare(frame, spec, dst)?;
    normalise_rows(frame, &mapper, 0, dst.as_mut_slice());
    Ok(())
}

/// Allocating form of [`normalise_into`].
pub fn f32_from_raw(frame: &RawFrame, spec: &NormaliseSpec) -> Result<Image<f32>, RawError> {
    let mut dst = Image::new(frame.width(), frame.height());
    normalise_into(frame, spec, &mut dst)?;
    Ok(dst)
}

/// The daemon's integer path: a `u16` frame in raw units with the black level removed
/// (`max(v - black[p], 0)`), optionally multiplied by per-colour gains in Q4.12 fixed point with
/// rounding, and clamped to `white - max(black)`. The result has black 0, white
/// `white - max(black)`, the same pattern, bit depth, metadata and no file gains (they have been
/// applied, or were not asked for).
pub fn u16_from_raw(frame: &RawFrame, gains: Option<[f32; 3]>) -> Result<RawFrame, RawError> {
    let lv = *frame.levels();
    let top = lv.white - lv.max_black();
    let mut q = [1u32 << GAIN_FRAC_BITS; 4];
    if let Some(g) = gains {
        check_gains(&g)?;
        for (p, qp) in q.iter_mut().enumerate() {
            let c = colour_index(frame.cfa().colour_at(p & 1, p >> 1));
            *qp = (g[c] * (1u32 << GAIN_FRAC_BITS) as f32).round() as u32;
        }
    }
    let round = 1u32 << (GAIN_FRAC_BITS - 1);
    let (w, h) = (frame.width(), frame.height());
    let stride = frame.stride();
    let mut out = vec![0u16; w * h];
    out.par_chunks_mut(w * STRIP_ROWS)
        .enumerate()
        .for_each(|(i, strip)| {
            for (dy, row) in strip.chunks_exact_mut(w).enumerate() {
                let y = i * STRIP_ROWS + dy;
                let pb = (y & 1) * 2;
                let b = [lv.black[pb], lv.black[pb + 1]];
                let g = [q[pb], q[pb + 1]];
                let start = y * stride;
                macro_rules! run {
                    ($src:expr) => {
                        for (x, (o, &v)) in row.iter_mut().zip($src).enumerate() {
                            let p = x & 1;
                            let d = (v as u16).saturating_sub(b[p]) as u32;
                            // d < 2^16 and g < 2^16 (gain < 16 in Q4.12): the product fits in u32.
                            let r = (d * g[p] + round) >> GAIN_FRAC_BITS;
                            *o = r.min(top as u32) as u16;
                        }
                    };
                }
                match frame.pixels() {
                    RawPixels::U8(v) => run!(&v[start..start + w]),
                    RawPixels::U16(v) => run!(&v[start..start + w]),
                }
            }
        });
    let levels = super::Levels::uniform(0, top);
    let mut f = RawFrame::new(
        w,
        h,
        w,
        RawPixels::U16(out),
        frame.cfa(),
        frame.bit_depth(),
        levels,
    )?;
    f.meta = frame.meta.clone();
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::{Cfa, Levels};

    fn spec(gains: Gains, compression: Compression) -> NormaliseSpec {
        NormaliseOptions { gains, compression }.build().unwrap()
    }

    fn close(a: &[f32], b: &[f32]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6)
    }

    fn frame() -> RawFrame {
        // RGGB 4x2, 10-bit, black per tile position [10, 20, 30, 40], white 1010.
        let px = vec![10, 520, 1010, 5, 530, 1000, 0, 1010];
        RawFrame::from_u16(
            4,
            2,
            px,
            Cfa::Rggb,
            10,
            Levels {
                black: [10, 20, 30, 40],
                white: 1010,
            },
        )
        .unwrap()
    }

    /// The plain per-pixel loop `row_tile_sums` replaces.
    fn plain_tile_sums(row: &[u16], white: u16, blacks: [u16; 2]) -> [(u64, u64); 2] {
        let mut acc = [(0u64, 0u64); 2];
        for (x, &v) in row.iter().enumerate() {
            if v < white {
                acc[x & 1].0 += u64::from(v.saturating_sub(blacks[x & 1]));
                acc[x & 1].1 += 1;
            }
        }
        acc
    }

    #[test]
    fn lane_sums_equal_the_plain_loop_at_any_width_with_saturated_and_black_values() {
        let mut state = 0x2545_f491_u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        // Widths around the 16-column lanes and past one 16 384-column block; values on both sides
        // of white and of the blacks, up to the u16 maximum.
        for w in [1, 2, 15, 16, 17, 33, 1919, 16_384, 16_385, 40_000] {
            let row: Vec<u16> = (0..w)
                .map(|_| match next() % 4 {
                    0 => u16::MAX - (next() % 3) as u16,
                    1 => (next() % 80) as u16,
                    _ => next() as u16,
                })
                .collect();
            for (white, blacks) in [(65_535, [0, 0]), (4095, [64, 70]), (1000, [60_000, 3])] {
                assert_eq!(
                    row_tile_sums(&row, white, blacks),
                    plain_tile_sums(&row, white, blacks),
                    "width {w} white {white}"
                );
            }
            let bytes: Vec<u8> = row.iter().map(|&v| v as u8).collect();
            let wide: Vec<u16> = bytes.iter().map(|&v| u16::from(v)).collect();
            assert_eq!(
                row_tile_sums(&bytes, 200, [16, 9]),
                plain_tile_sums(&wide, 200, [16, 9])
            );
        }
    }

    #[test]
    fn hand_computed_linear_with_clamping() {
        let img = f32_from_raw(&frame(), &spec(Gains::None, Compression::None)).unwrap();
        // Row 0: (10-10)/1000, (520-20)/990, (1010-10)/1000, max(5-20,0)
        // Row 1: (530-30)/980, (1000-40)/970, max(0-30,0), (1010-40)/970 = 1
        let want = [
            0.0,
            500.0 / 990.0,
            1.0,
            0.0,
            500.0 / 980.0,
            960.0 / 970.0,
            0.0,
            1.0,
        ];
        for (a, b) in img.as_slice().iter().zip(want) {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
    }

    #[test]
    fn gains_and_compression_hand_computed() {
        let f =
            RawFrame::from_u8(2, 2, vec![100, 100, 100, 100], Cfa::Grbg, Levels::uniform(0, 200)).unwrap();
        // GRBG: G R / B G. Gains r 1.5, b 3 → R 0.75, B 1.5 → clamped 1.
        let img = f32_from_raw(&f, &spec(Gains::Fixed([1.5, 1.0, 3.0]), Compression::None)).unwrap();
        assert!(
            close(img.as_slice(), &[0.5, 0.75, 1.0, 0.5]),
            "{:?}",
            img.as_slice()
        );
        let img = f32_from_raw(&f, &spec(Gains::None, Compression::Sqrt)).unwrap();
        assert!(img.as_slice().iter().all(|&v| (v - 0.5f32.sqrt()).abs() < 1e-7));
        let img = f32_from_raw(&f, &spec(Gains::None, Compression::Gamma(1.0 / 2.2))).unwrap();
        assert!(img
            .as_slice()
            .iter()
            .all(|&v| (v - 0.5f32.powf(1.0 / 2.2)).abs() < 1e-7));
        // Gamma 1 is the identity.
        let a = f32_from_raw(&frame(), &spec(Gains::None, Compression::Gamma(1.0))).unwrap();
        let b = f32_from_raw(&frame(), &spec(Gains::None, Compression::None)).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn gains_modes() {
        // RGGB 2x2 tiles: R 40, G 80, B 20 above black 0, white 255 → grey world r 2, b 4.
        let f = RawFrame::from_u8(
            4,
            2,
            vec![40, 80, 40, 80, 80, 20, 80, 20],
            Cfa::Rggb,
            Levels::uniform(0, 255),
        )
        .unwrap();
        let s = spec(Gains::GreyWorld, Compression::None);
        assert!(close(&s.gains_for(&f).unwrap(), &[2.0, 1.0, 4.0]));
        let img = f32_from_raw(&f, &s).unwrap();
        assert!(img.as_slice().iter().all(|&v| (v - 80.0 / 255.0).abs() < 1e-6));
        // Auto without file gains = grey world; with file gains = file gains.
        let auto = spec(Gains::Auto, Compression::None);
        assert!(close(&auto.gains_for(&f).unwrap(), &[2.0, 1.0, 4.0]));
        let fg = f.clone().with_wb_gains([1.5, 1.0, 2.5]);
        assert_eq!(auto.gains_for(&fg).unwrap(), [1.5, 1.0, 2.5]);
        assert_eq!(
            spec(Gains::FromFile, Compression::None).gains_for(&fg).unwrap(),
            [1.5, 1.0, 2.5]
        );
        assert!(matches!(
            spec(Gains::FromFile, Compression::None).gains_for(&f),
            Err(RawError::NoFileGains { .. })
        ));
        assert_eq!(
            spec(Gains::None, Compression::None).gains_for(&fg).unwrap(),
            [1.0; 3]
        );
        // Saturated pixels are left out of the grey-world means.
        let sat = RawFrame::from_u8(
            4,
            2,
            vec![40, 80, 255, 80, 80, 20, 80, 20],
            Cfa::Rggb,
            Levels::uniform(0, 255),
        )
        .unwrap();
        assert!(close(&grey_world_gains(&sat), &[2.0, 1.0, 4.0]));
    }

    #[test]
    fn options_parse_from_text_and_toml() {
        assert_eq!("none".parse::<Gains>().unwrap(), Gains::None);
        assert_eq!("file".parse::<Gains>().unwrap(), Gains::FromFile);
        assert_eq!("Grey-World".parse::<Gains>().unwrap(), Gains::GreyWorld);
        assert_eq!("auto".parse::<Gains>().unwrap(), Gains::Auto);
        assert_eq!(
            "1.5, 1, 2".parse::<Gains>().unwrap(),
            Gains::Fixed([1.5, 1.0, 2.0])
        );
        assert!("1,2".parse::<Gains>().is_err());
        assert!("warm".parse::<Gains>().is_err());
        assert_eq!("sqrt".parse::<Compression>().unwrap(), Compression::Sqrt);
        assert_eq!(
            "gamma:0.5".parse::<Compression>().unwrap(),
            Compression::Gamma(0.5)
        );
        assert!("gamma".parse::<Compression>().is_err());
        let o: NormaliseOptions =
            toml::from_str("gains = { fixed = [2.0, 1.0, 1.5] }\ncompression = { gamma = 0.45 }").unwrap();
        assert_eq!(o.gains, Gains::Fixed([2.0, 1.0, 1.5]));
        assert_eq!(o.compression, Compression::Gamma(0.45));
        let o: NormaliseOptions = toml::from_str("gains = \"grey-world\"").unwrap();
        assert_eq!(
            o,
            NormaliseOptions {
                gains: Gains::GreyWorld,
                ..NormaliseOptions::default()
            }
        );
        assert!(toml::from_str::<NormaliseOptions>("gain = \"none\"").is_err());
    }

    #[test]
    fn bad_options_are_refused() {
        for g in [
            [0.0, 1.0, 1.0],
            [1.0, f32::NAN, 1.0],
            [1.0, 1.0, 16.0],
            [-1.0, 1.0, 1.0],
        ] {
            let o = NormaliseOptions {
                gains: Gains::Fixed(g),
                compression: Compression::None,
            };
            assert!(matches!(o.build(), Err(RawError::Param { .. })), "{g:?}");
        }
        for e in [0.0, -0.5, 5.0, f32::INFINITY] {
            let o = NormaliseOptions {
                gains: Gains::None,
                compression: Compression::Gamma(e),
            };
            assert!(
                matches!(o.build(), Err(RawError::Param { name: "gamma", .. })),
                "{e}"
            );
        }
        // Bad gains from a file are refused when used.
        let f = frame().with_wb_gains([f32::NAN, 1.0, 1.0]);
        assert!(spec(Gains::FromFile, Compression::None).gains_for(&f).is_err());
    }

    #[test]
    fn parallel_equals_serial() {
        // 50 rows: several strips plus a partial one; odd width; strided u8 and u16.
        let (w, h) = (37, 50);
        let data: Vec<u16> = (0..w * h).map(|i| ((i * 7919) % 4096) as u16).collect();
        let f16 = RawFrame::from_u16(
            w,
            h,
            data.clone(),
            Cfa::Gbrg,
            12,
            Levels {
                black: [64, 70, 80, 90],
                white: 4000,
            },
        )
        .unwrap();
        let data8: Vec<u8> = (0..(w + 3) * h).map(|i| (i * 31 % 256) as u8).collect();
        let f8 = RawFrame::new(
            w,
            h,
            w + 3,
            RawPixels::U8(data8),
            Cfa::Bggr,
            8,
            Levels::uniform(16, 250),
        )
        .unwrap();
        for f in [f16, f8] {
            for c in [Compression::None, Compression::Sqrt, Compression::Gamma(0.45)] {
                let s = spec(Gains::GreyWorld, c);
                let mut a = Image::new(0, 0);
                let mut b = Image::new(0, 0);
                normalise_into(&f, &s, &mut a).unwrap();
                normalise_into_serial(&f, &s, &mut b).unwrap();
                assert_eq!(a, b);
                assert_eq!(a.dimensions(), (w, h));
                assert!(a.as_slice().iter().all(|v| (0.0..=1.0).contains(v)));
            }
        }
    }

    #[test]
    fn table_path_equals_formula_path_bit_for_bit() {
        // Values above the bit depth's range too (RawFrame does not forbid them).
        let (w, h) = (64, 40);
        let data: Vec<u16> = (0..w * h).map(|i| (i * 40503 % 1100) as u16).collect();
        let f16 = RawFrame::from_u16(
            w,
            h,
            data,
            Cfa::Grbg,
            10,
            Levels {
                black: [30, 31, 32, 33],
                white: 1000,
            },
        )
        .unwrap();
        let data8: Vec<u8> = (0..w * h).map(|i| (i * 97 % 256) as u8).collect();
        let f8 = RawFrame::from_u8(w, h, data8, Cfa::Rggb, Levels::uniform(10, 240)).unwrap();
        for f in [f16, f8] {
            for c in [Compression::None, Compression::Sqrt, Compression::Gamma(0.45)] {
                let params = TileParams::new(&f, &[0.7, 1.0, 2.5], c);
                let mut a = vec![0f32; w * h];
                let mut b = vec![0f32; w * h];
                normalise_rows(&f, &Mapper::new(&f, params, false), 0, &mut a);
                normalise_rows(&f, &Mapper::new(&f, params, true), 0, &mut b);
                assert_eq!(a, b, "{c:?}");
            }
        }
    }

    #[test]
    fn gain_below_one_applies_after_clamping_to_white() {
        // Above white: l = 1, then gain 0.5 → 0.5 (not (v - black) / range * gain).
        let f = RawFrame::from_u16(2, 1, vec![1023, 900], Cfa::Rggb, 10, Levels::uniform(0, 900)).unwrap();
        let img = f32_from_raw(&f, &spec(Gains::Fixed([0.5, 1.0, 1.0]), Compression::None)).unwrap();
        assert_eq!(img.as_slice(), &[0.5, 1.0]);
    }

    #[test]
    fn u16_path_equals_scalar_formula_over_many_strips() {
        // Strided, 3.5 strips, every tile position with its own black level.
        let (w, h, stride) = (21, 3 * STRIP_ROWS + 7, 24);
        let data: Vec<u16> = (0..stride * h)
            .map(|i| ((i * 2654435761usize) % 16384) as u16)
            .collect();
        let lv = Levels {
            black: [600, 610, 620, 630],
            white: 15520,
        };
        let f = RawFrame::new(w, h, stride, RawPixels::U16(data), Cfa::Bggr, 14, lv).unwrap();
        let gains = [1.9, 1.0, 1.45];
        let out = u16_from_raw(&f, Some(gains)).unwrap();
        let top = 15520 - 630;
        for y in 0..h {
            for x in 0..w {
                let c = colour_index(f.cfa().colour_at(x, y));
                let q = (gains[c] * 4096.0).round() as u32;
                let d = f.value(x, y).saturating_sub(f.black_at(x, y)) as u32;
                let want = ((d * q + 2048) >> 12).min(top);
                assert_eq!(out.value(x, y) as u32, want, "({x}, {y})");
            }
        }
    }

    #[test]
    fn u16_path_matches_float_path() {
        let f = frame();
        let out = u16_from_raw(&f, None).unwrap();
        // black removed, clamped to white - max black = 970
        assert_eq!(out.to_u16_vec(), vec![0, 500, 970, 0, 500, 960, 0, 970]);
        assert_eq!(*out.levels(), Levels::uniform(0, 970));
        let g = u16_from_raw(&f, Some([2.0, 1.0, 0.5])).unwrap();
        // RGGB: R at (0,0),(2,0); B at (1,1),(3,1).
        assert_eq!(g.to_u16_vec(), vec![0, 500, 970, 0, 500, 480, 0, 485]);
        // Q4.12 rounding: gain 1.3 on 3 → 3.9 → 4.
        let f = RawFrame::from_u8(2, 2, vec![3, 3, 3, 3], Cfa::Rggb, Levels::uniform(0, 255)).unwrap();
        let g = u16_from_raw(&f, Some([1.3, 1.0, 1.0])).unwrap();
        assert_eq!(g.to_u16_vec(), vec![4, 3, 3, 3]);
        assert!(u16_from_raw(&f, Some([0.0, 1.0, 1.0])).is_err());
    }
}
