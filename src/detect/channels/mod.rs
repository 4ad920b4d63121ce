//! Aggregated channel features (ACF, Dollár et al. 2014) computed on a Bayer mosaic, and the same
//! features on colour and grey images for comparisons.
//!
//! # Overview
//!
//! Ten channels, each averaged over blocks of `SHRINK = 4` pixels (2x2 super-pixels on a mosaic):
//! three colour channels (CIE L\*u\*v\* in Dollár's scaling), the normalised gradient magnitude,
//! and six orientation channels holding the normalised magnitude of the pixels whose unsigned
//! gradient orientation falls in each 30° bin. A boosted classifier ([`crate::detect::boost`])
//! reads single entries of these maps; [`pyramid()`] builds them over scales (exact once per octave,
//! power-law approximations in between).
//!
//! ```
//! use mosaicd::detect::channels::{channels, ChannelInput, ChannelSpec, N_CHANNELS};
//! use mosaicd::image::Image;
//! use mosaicd::raw::Cfa;
//! // A flat grey mosaic (R = G = B = 128): no gradient, the same colour everywhere.
//! let m = Image::filled(32, 24, 128.0f32);
//! let c = channels(&ChannelInput::Mosaic { image: m.view(), cfa: Cfa::Rggb }, &ChannelSpec::default()).unwrap();
//! assert_eq!((c.width(), c.height(), N_CHANNELS), (8, 6, 10));
//! assert_eq!(c.get(3, 4, 2), 0.0); // gradient magnitude channel
//! assert!((c.get(0, 0, 0) - c.get(0, 7, 5)).abs() < 1e-6); // L is flat
//! ```
//!
//! # The math
//!
//! Input values `I` are in 8-bit units and scaled to `[0, 1]` (`I/255`); a mosaic is the frame in
//! its tone ([`MosaicTone`](crate::raw::MosaicTone): `srgb` applies the frame's white balance first).
//!
//! 1. **Input smoothing** (Dollár's `pColor.smooth`; off in his INRIA detector and by default
//!    here): the separable triangle filter of radius `r`, `t_r(k) = (r + 1 − |k|)/(r + 1)²`,
//!    `|k| ≤ r` ([`triangle_taps`], also for `r < 1`). On a mosaic the taps are two pixels
//!    apart (`I(x + 2k)`), so the filter runs on each colour plane and never mixes colours.
//!    Borders are symmetric within a plane (`dcba|abcd`, Dollár's `convTri` padding).
//! 2. **Colour.** `(r, g, b)` → `Y = 0.222015 r + 0.706655 g + 0.071330 b` (and `X`, `Z` with
//!    Dollár's `rgbConvert` matrix), `L = (116·Y^⅓ − 16)/270` (`903.3·Y/270` below
//!    `Y = (6/29)³`), `u = L·(13·4X/D − 13·0.197833) + 88/270`, `v = L·(13·9Y/D − 13·0.468331) +
//!    134/270`, `D = X + 15Y + 3Z`. Like Dollár we apply it to the (sRGB-encoded) values as they
//!    are, without linearising. On a mosaic the colour of a 2x2 super-pixel is
//!    `(R, (G₁ + G₂)/2, B)`, all measured, none interpolated; grey images use `r = g = b`.
//! 3. **Gradient.** `gx = (I(x+1, y) − I(x−1, y))/2`, `gy` likewise. On a mosaic `x ± 1` always
//!    have the same colour (the paper's same-colour central difference). Borders reflect-101
//!    (`I(−1) = I(1)`), which keeps colours on a mosaic and gives `gx = 0` on the edge columns.
//!    Colour images use, per pixel, the channel of largest magnitude (Dollár's `colorChn = 0`
//!    over R, G, B); grey and mosaic images have one plane. `M = √(gx² + gy²)`,
//!    `θ = atan2(gy, gx)` folded into `[0, π)`.
//! 4. **Normalisation** (Dollár's `normRad = 5`, `normConst = 0.005`):
//!    `M̃ = M / (t₅ ∗ M + 0.005)`, the triangle filter applied at full resolution (step 1 also on a
//!    mosaic: `M` is one scalar field).
//! 5. **Orientation channels** (`nOrients = 6`, `softBin = 0`): pixel `p` votes `M̃(p)` into bin
//!    `round(6θ/π) mod 6` (bin centres at 0°, 30°, …, 150°) of its block.
//! 6. **Aggregation** (`shrink = 4`): every channel is the mean over a block of 4x4 pixels; on a
//!    mosaic the colour channels are the mean of the 2x2 super-pixels of the block. Output size
//!    `⌊W/4⌋ x ⌊H/4⌋`; pixels beyond are ignored.
//! 7. **Output smoothing** (`pPyramid.smooth`, 0.5 in Dollár's INRIA detector and by default
//!    here: taps `[1, 7.6, 1]/9.6`): on every aggregated channel
//!    ([`smooth_channels`]; [`channels`] applies it, [`channels_unsmoothed`] does not, for the
//!    pyramid, which smooths after approximating).
//!
//! Channel order: `L, U, V, M, H₀ … H₅` (Dollár's).
//!
//! # Where we differ from Dollár
//!
//! * Gradients are taken on the input values (mosaic sites, or max over R, G, B) rather than on
//!   the LUV channels (Dollár's `gradientMag` of the LUV image, max over L, u, v). On a mosaic
//!   there is no per-pixel LUV; the colour images use R, G, B so that the mosaic and colour
//!   features differ only by demosaicing. `normConst` is the same, on a scale where RGB spans 1
//!   (L spans about 0.37).
//! * The mosaic's colour channels are smoothed per colour plane before the LUV conversion;
//!   Dollár smooths the LUV image. LUV is nonlinear, so the two differ slightly.
//! * Gradient borders are reflect-101 (zero on the edge rows and columns) instead of Dollár's
//!   one-sided difference, which would subtract different colours on a mosaic.
//! * Orientation uses `atan2` (Dollár: an `acos` table), identical up to float rounding at bin
//!   edges.
//!
//! # References
//!
//! P. Dollár, R. Appel, S. Belongie, P. Perona, "Fast Feature Pyramids for Object Detection",
//! PAMI 2014. P. Dollár, Z. Tu, P. Perona, S. Belongie, "Integral Channel Features", BMVC 2009.
//! W. Zhou, L. Zhang, S. Gao, X. Lou, "Gradient-based Feature Extraction From Raw Bayer Pattern
//! Images" (the same-colour central difference).

mod kernels;
pub mod pyramid;
#[cfg(test)]
mod tests;

use rayon::prelude::*;
use thiserror::Error;

use crate::image::ImageView;
use crate::kernels::Isa;
use crate::raw::{Cfa, Colour};

use kernels::{bin_edges, orient_bin};
pub use kernels::{luv_from_rgb, N_ORIENTS};
pub use pyramid::{measure_lambdas, pyramid, ChannelPyramid, Level, PyramidOptions};

/// Number of channels: L, U, V, magnitude, six orientations.
pub const N_CHANNELS: usize = 10;
/// Aggregation block in pixels (Dollár's `shrink`): 2x2 super-pixels on a mosaic.
pub const SHRINK: usize = 4;
// the aggregation kernels sum blocks of this side
const _: () = assert!(kernels::BLOCK == SHRINK);
/// Index of the magnitude channel; the orientation channels follow it.
pub const MAG_CHANNEL: usize = 3;
/// Rows per rayon task.
const ROWS_PER_TASK: usize = 16;
/// Largest smoothing radius accepted (a larger one is almost certainly a unit error).
const MAX_RADIUS: f32 = 32.0;
/// Most taps of a triangle filter (radius [`MAX_RADIUS`]).
const MAX_TAPS: usize = 2 * MAX_RADIUS as usize + 1;

/// Errors from channel computation.
#[derive(Debug, PartialEq, Error)]
pub enum ChannelsError {
    /// The image is smaller than one aggregation block (or, for a pyramid, one window).
    #[error("image {width}x{height} is smaller than the minimum {min_width}x{min_height}")]
    TooSmall {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Minimum width.
        min_width: usize,
        /// Minimum height.
        min_height: usize,
    },
    /// A mosaic with odd width or height.
    #[error("mosaic {width}x{height}: width and height must be even")]
    OddMosaic {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
    /// An option out of range.
    #[error("channel option {name} = {value}: {allowed}")]
    BadOption {
        /// Option.
        name: &'static str,
        /// Offending value.
        value: String,
        /// What is allowed.
        allowed: &'static str,
    },
    /// A resize inside the pyramid failed.
    #[error(transparent)]
    Resize(#[from] crate::resize::ResizeError),
}

/// What the channels are computed from; values in 8-bit units (0..=255).
#[derive(Debug, Clone, Copy)]
pub enum ChannelInput<'a> {
    /// A Bayer mosaic in its tone (see the module docs), even width and height.
    Mosaic {
        /// Pixels.
        image: ImageView<'a, f32>,
        /// Pattern (for the colour of each super-pixel).
        cfa: Cfa,
    },
    /// RGB.
    Rgb8(ImageView<'a, [u8; 3]>),
    /// Grey.
    GreyU8(ImageView<'a, u8>),
    /// Float grey.
    GreyF32(ImageView<'a, f32>),
    /// Float R, G, B planes (a resized colour image).
    RgbF32([ImageView<'a, f32>; 3]),
}

impl ChannelInput<'_> {
    /// (width, height) in pixels.
    pub fn dimensions(&self) -> (usize, usize) {
        match self {
            ChannelInput::Mosaic { image, .. } | ChannelInput::GreyF32(image) => {
                (image.width(), image.height())
            }
            ChannelInput::Rgb8(v) => (v.width(), v.height()),
            ChannelInput::GreyU8(v) => (v.width(), v.height()),
            ChannelInput::RgbF32(p) => (p[0].width(), p[0].height()),
        }
    }
}

/// Channel options, named after Dollár's (`chnsCompute`), defaults equal to his.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ChannelOptions {
    /// Triangle radius of the input smoothing (`pColor.smooth`; 0 = off).
    pub input_smooth: f32,
    /// Triangle radius of the magnitude normalisation (`pGradMag.normRad`; 0 = no normalisation).
    pub norm_radius: f32,
    /// Constant of the normalisation (`pGradMag.normConst`).
    pub norm_const: f32,
    /// Triangle radius applied to the aggregated channels (`pPyramid.smooth`).
    pub output_smooth: f32,
}

impl Default for ChannelOptions {
    /// Dollár's INRIA detector (`acfDemoInria`): no input smoothing, output smoothing 0.5,
    /// normalisation radius 5 and constant 0.005 (`chnsCompute`'s own defaults smooth both by 1).
    fn default() -> Self {
        Self {
            input_smooth: 0.0,
            norm_radius: 5.0,
            norm_const: 0.005,
            output_smooth: 0.5,
        }
    }
}

/// Validated [`ChannelOptions`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ChannelSpec {
    opts: ChannelOptions,
}

impl ChannelSpec {
    /// Check `opts`.
    pub fn new(opts: ChannelOptions) -> Result<Self, ChannelsError> {
        for (name, r) in [
            ("input_smooth", opts.input_smooth),
            ("norm_radius", opts.norm_radius),
            ("output_smooth", opts.output_smooth),
        ] {
            let ok = (0.0..=1.0).contains(&r) || ((0.0..=MAX_RADIUS).contains(&r) && r.fract() == 0.0);
            if !ok {
                return Err(ChannelsError::BadOption {
                    name,
                    value: r.to_string(),
                    allowed: "a triangle radius in 0..=1 or an integer up to 32",
                });
            }
        }
        if !(opts.norm_const.is_finite() && opts.norm_const > 0.0) {
            return Err(ChannelsError::BadOption {
                name: "norm_const",
                value: opts.norm_const.to_string(),
                allowed: "finite and > 0",
            });
        }
        Ok(Self { opts })
    }

    /// The options.
    pub fn options(&self) -> &ChannelOptions {
        &self.opts
    }
}

/// Float buffers of dropped channel maps and of the channel pass, reused by the next ones: a
/// 1080p pyramid allocates about 30 MB of channels per frame, and fresh pages cost a page fault
/// each (a quarter of the channel time before the pool). Holds at most `POOL_MAX_VALUES` values
/// in at most `POOL_MAX_BUFFERS` buffers; a buffer is zeroed, or handed only to a caller that
/// writes every value of it (no `memset`), before it is read, so reuse changes no value.
mod pool {
    use std::sync::Mutex;

    /// At most this many `f32` of capacity are kept (128 MB).
    const POOL_MAX_VALUES: usize = 32 << 20;
    /// At most this many buffers are kept (each allocation scans them; a 1080p frame returns
    /// about 90: 25 levels, the band outputs, the smoothing rows).
    const POOL_MAX_BUFFERS: usize = 512;

    static POOL: Mutex<(Vec<Vec<f32>>, usize)> = Mutex::new((Vec::new(), 0));

    /// The pool's smallest buffer of capacity at least `n`, if any.
    fn pooled(n: usize) -> Option<Vec<f32>> {
        let mut p = POOL.lock().unwrap_or_else(|e| e.into_inner());
        let best =
            p.0.iter()
                .enumerate()
                .filter(|(_, b)| b.capacity() >= n)
                .min_by_key(|(_, b)| b.capacity())
                .map(|(i, _)| i)?;
        let b = p.0.swap_remove(best);
        p.1 -= b.capacity();
        Some(b)
    }

    /// A buffer of `n` zeros, from the pool when one is large enough (the smallest such).
    pub(super) fn zeros(n: usize) -> Vec<f32> {
        let Some(mut v) = pooled(n) else {
            return vec![0.0; n];
        };
        v.clear();
        v.resize(n, 0.0);
        v
    }

    /// A buffer of `n` values for a caller that writes every one of them: from the pool when
    /// one is large enough (the smallest such) with the values of its last use (no `memset`;
    /// only values past its previous length are zeroed), otherwise new zeros.
    pub(super) fn overwritten(n: usize) -> Vec<f32> {
        let Some(mut v) = pooled(n) else {
            return vec![0.0; n];
        };
        v.truncate(n);
        v.resize(n, 0.0);
        v
    }

    /// Give `v` back (dropped instead when the pool is full).
    pub(super) fn give(v: Vec<f32>) {
        let c = v.capacity();
        if c == 0 {
            return;
        }
        let mut p = POOL.lock().unwrap_or_else(|e| e.into_inner());
        if p.1 + c <= POOL_MAX_VALUES && p.0.len() < POOL_MAX_BUFFERS {
            p.1 += c;
            p.0.push(v);
        }
    }
}

/// Ten aggregated channel maps of `width x height` blocks, planar (channel-major, then rows).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Channels {
    width: usize,
    height: usize,
    data: Vec<f32>,
}

impl Drop for Channels {
    fn drop(&mut self) {
        pool::give(std::mem::take(&mut self.data));
    }
}

impl Channels {
    /// Zeros of `width x height` blocks.
    pub fn zeros(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: pool::zeros(N_CHANNELS * width * height),
        }
    }

    /// Width in blocks.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in blocks.
    pub fn height(&self) -> usize {
        self.height
    }

    /// All channels, planar.
    pub fn as_slice(&self) -> &[f32] {
        &self.data
    }

    /// Channel `c`, row-major.
    pub fn plane(&self, c: usize) -> &[f32] {
        let n = self.width * self.height;
        &self.data[c * n..(c + 1) * n]
    }

    /// Channel `c`, mutable.
    pub fn plane_mut(&mut self, c: usize) -> &mut [f32] {
        let n = self.width * self.height;
        &mut self.data[c * n..(c + 1) * n]
    }

    /// Channel `c` at block `(x, y)`.
    pub fn get(&self, c: usize, x: usize, y: usize) -> f32 {
        self.data[(c * self.height + y) * self.width + x]
    }

    /// The features of the `ww x wh`-block window at block `(x0, y0)`, in the order the
    /// classifier indexes them: `(c·wh + y)·ww + x`. `None` if the window does not fit.
    pub fn window(&self, x0: usize, y0: usize, ww: usize, wh: usize) -> Option<Vec<f32>> {
        if x0 + ww > self.width || y0 + wh > self.height {
            return None;
        }
        let mut out = Vec::with_capacity(N_CHANNELS * ww * wh);
        for c in 0..N_CHANNELS {
            let p = self.plane(c);
            for y in y0..y0 + wh {
                out.extend_from_slice(&p[y * self.width + x0..y * self.width + x0 + ww]);
            }
        }
        Some(out)
    }
}

/// Taps of Dollár's `convTri` of radius `r`: for an integer `r ≥ 1`, `(r + 1 − |k|)/(r + 1)²`,
/// `|k| ≤ r`; for `0 < r ≤ 1`, `[1, p, 1]/(p + 2)` with `p = 12/(r(r + 2)) − 2` (equal to the
/// integer rule at `r = 1`); `[1]` for `r = 0`.
pub fn triangle_taps(r: f32) -> Vec<f32> {
    if r <= 0.0 {
        vec![1.0]
    } else if r <= 1.0 {
        let p = 12.0 / (r * (r + 2.0)) - 2.0;
        let n = 1.0 / (p + 2.0);
        vec![n, p * n, n]
    } else {
        let r = r.round() as usize;
        let norm = 1.0 / ((r + 1) * (r + 1)) as f32;
        (0..=2 * r)
            .map(|i| (r + 1 - i.abs_diff(r)) as f32 * norm)
            .collect()
    }
}

/// For each position `0..n` the `2r + 1` indices `x + k·step`, `|k| ≤ r`, mirrored symmetrically
/// (`dcba|abcd`) within `x`'s phase `x mod step` (repeatedly, for tiny sizes).
fn mirror_table(n: usize, r: usize, step: usize) -> Vec<usize> {
    let mut t = Vec::with_capacity(n * (2 * r + 1));
    for x in 0..n {
        let ph = x % step;
        let np = (n - ph).div_ceil(step) as isize; // samples of this phase
        for k in -(r as isize)..=r as isize {
            let mut p = (x / step) as isize + k;
            loop {
                if p < 0 {
                    p = -p - 1;
                } else if p >= np {
                    p = 2 * np - p - 1;
                } else {
                    break;
                }
            }
            t.push(p as usize * step + ph);
        }
    }
    t
}

/// The separable triangle filter of one radius on `w x h` values, output row by output row.
struct Triangle {
    taps: Vec<f32>,
    /// Mirrored column indices, `taps.len()` per column.
    xi: Vec<usize>,
    /// Mirrored row indices, `taps.len()` per row.
    yi: Vec<usize>,
    step: usize,
    /// Interior columns `lo..hi`: every tap inside the row.
    lo: usize,
    hi: usize,
}

impl Triangle {
    /// `None` for radius 0 or an empty plane.
    fn new(w: usize, h: usize, radius: f32, step: usize) -> Option<Self> {
        if radius <= 0.0 || w == 0 || h == 0 {
            return None;
        }
        let taps = triangle_taps(radius);
        let r = taps.len() / 2;
        Some(Self {
            xi: mirror_table(w, r, step),
            yi: mirror_table(h, r, step),
            taps,
            step,
            lo: r * step,
            hi: w.saturating_sub(r * step),
        })
    }

    /// The source rows output row `y` reads, in tap order.
    fn rows_of(&self, y: usize) -> &[usize] {
        let n = self.taps.len();
        &self.yi[y * n..(y + 1) * n]
    }

    /// The whole filter: `dst = t ∗ src`, both planes of rows of `w` values, rows in parallel
    /// (each row [`Triangle::row`], the same arithmetic for any thread count).
    fn filter(&self, isa: Isa, src: &[f32], w: usize, dst: &mut [f32]) {
        dst.par_chunks_mut(w * ROWS_PER_TASK)
            .enumerate()
            .for_each(|(i, chunk)| {
                let mut tmp = vec![0.0f32; w];
                for (j, row) in chunk.chunks_mut(w).enumerate() {
                    self.row(
                        isa,
                        i * ROWS_PER_TASK + j,
                        |sy| &src[sy * w..(sy + 1) * w],
                        &mut tmp,
                        row,
                    );
                }
            });
    }

    /// Output row `y` into `out` (`w` values): the vertical pass `tmp = Σ_k t_k · src(y_k)` (source
    /// rows through `src`, in tap order, from 0), then the horizontal pass (the same sum along the
    /// row; mirrored taps at the borders).
    fn row<'s>(
        &self,
        isa: Isa,
        y: usize,
        src: impl Fn(usize) -> &'s [f32],
        tmp: &mut [f32],
        out: &mut [f32],
    ) {
        let (w, n) = (out.len(), self.taps.len());
        // the tap rows on the stack (no allocation per row: the smoothing filters ~17 000 short
        // rows per 1080p frame)
        let mut stack: [&[f32]; MAX_TAPS] = [&[]; MAX_TAPS];
        let mut heap: Vec<&[f32]>;
        let rows: &mut [&[f32]] = if n <= MAX_TAPS {
            &mut stack[..n]
        } else {
            heap = vec![&[]; n];
            &mut heap
        };
        for (r, &sy) in rows.iter_mut().zip(self.rows_of(y)) {
            *r = src(sy);
        }
        kernels::taps_sum(isa, tmp, rows, &self.taps);
        let (lo, hi) = (self.lo, self.hi);
        if lo < hi {
            for (k, r) in rows.iter_mut().enumerate() {
                *r = &tmp[k * self.step..k * self.step + (hi - lo)];
            }
            kernels::taps_sum(isa, &mut out[lo..hi], rows, &self.taps);
        }
        for x in (0..lo.min(w)).chain(hi.max(lo)..w) {
            out[x] = self
                .taps
                .iter()
                .zip(&self.xi[x * n..(x + 1) * n])
                .map(|(t, &sx)| t * tmp[sx])
                .sum();
        }
    }
}

/// Separable triangle filter of radius `radius` ([`triangle_taps`]) with taps `step` pixels
/// apart, borders symmetric within each phase (`step = 2`: within each colour plane). `src` and
/// `dst` are `w x h`. Rows in parallel; each output row is the vertical pass (a sum of scaled
/// source rows) followed by the horizontal pass, the same arithmetic for any thread count.
pub fn triangle_filter(src: &[f32], w: usize, h: usize, radius: f32, step: usize, dst: &mut Vec<f32>) {
    triangle_filter_on(crate::kernels::isa(), src, w, h, radius, step, dst);
}

/// [`triangle_filter`] on the kernel path `isa`.
fn triangle_filter_on(
    isa: Isa,
    src: &[f32],
    w: usize,
    h: usize,
    radius: f32,
    step: usize,
    dst: &mut Vec<f32>,
) {
    dst.clear();
    let Some(t) = Triangle::new(w, h, radius, step) else {
        dst.extend_from_slice(src);
        return;
    };
    dst.resize(w * h, 0.0);
    t.filter(isa, src, w, dst);
}

/// Smooth every channel with the triangle filter of radius `r` (step 1, symmetric borders).
pub fn smooth_channels(ch: &mut Channels, r: f32) {
    smooth_channels_on(crate::kernels::isa(), ch, r);
}

/// [`smooth_channels`] on the kernel path `isa`.
fn smooth_channels_on(isa: Isa, ch: &mut Channels, r: f32) {
    if r <= 0.0 {
        return;
    }
    let (w, h) = (ch.width, ch.height);
    let Some(t) = Triangle::new(w, h, r, 1) else {
        return;
    };
    // one filter (taps, mirror tables) for the ten planes, written into a new buffer that then
    // replaces the channels' (no copy back); each row the arithmetic of `triangle_filter`
    // every value written by the filter
    let mut out = pool::overwritten(N_CHANNELS * w * h);
    let src = ch.as_slice();
    out.par_chunks_mut(w * h)
        .enumerate()
        .for_each(|(c, plane)| t.filter(isa, &src[c * w * h..(c + 1) * w * h], w, plane));
    pool::give(std::mem::replace(&mut ch.data, out));
}

/// The input as planes scaled to `[0, 1]` (one plane, or R, G, B), and the tap step of the input
/// smoothing (2 on a mosaic).
fn planes_of(input: &ChannelInput) -> (Vec<Vec<f32>>, usize) {
    const S: f32 = 1.0 / 255.0;
    let (w, h) = input.dimensions();
    let f32_plane = |v: &ImageView<'_, f32>| -> Vec<f32> {
        (0..h).flat_map(|y| v.row(y).iter().map(|p| p * S)).collect()
    };
    match input {
        ChannelInput::Mosaic { image, .. } => (vec![f32_plane(image)], 2),
        ChannelInput::GreyF32(v) => (vec![f32_plane(v)], 1),
        ChannelInput::GreyU8(v) => (
            vec![(0..h)
                .flat_map(|y| v.row(y).iter().map(|&p| p as f32 * S))
                .collect()],
            1,
        ),
        ChannelInput::Rgb8(v) => (
            (0..3)
                .map(|k| {
                    (0..h)
                        .flat_map(|y| v.row(y)[..w].iter().map(move |p| p[k] as f32 * S))
                        .collect()
                })
                .collect(),
            1,
        ),
        ChannelInput::RgbF32(p) => (p.iter().map(f32_plane).collect(), 1),
    }
}

/// Block rows per task of the channel pass (64 pixel rows; each task recomputes the
/// normalisation's halo of `norm_radius` magnitude rows above and below).
const BLOCK_ROWS_PER_TASK: usize = 16;

/// Per-thread buffers of the channel pass, reused across tasks and frames (a task writes every
/// value it reads first): no full-resolution buffer is allocated per frame.
#[derive(Default)]
struct Scratch {
    /// The task's input rows of every plane, scaled to `[0, 1]`.
    inp: Vec<f32>,
    /// Gradient magnitude and orientation bin of the task's rows and halo.
    mag: Vec<f32>,
    bin: Vec<u8>,
    /// `(M², gx, gy)` of the plane of largest magnitude (colour inputs).
    best: Vec<[f32; 3]>,
    /// The triangle filter's vertical pass, the smoothed magnitude, the normalised block rows.
    tmp: Vec<f32>,
    norm: Vec<f32>,
    v: Vec<f32>,
    /// The colour pass: R, G, B and L, U, V of one block row.
    luv: Vec<f32>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// The input rows `lo..hi` of every plane of `src` (rows of `w` values, multiplied by `scale`)
/// into `buf`, plane after plane.
fn scaled_rows(src: &[ImageView<'_, f32>], scale: f32, w: usize, lo: usize, hi: usize, buf: &mut Vec<f32>) {
    buf.clear();
    for p in src {
        for y in lo..hi {
            buf.extend(p.row(y)[..w].iter().map(|v| v * scale));
        }
    }
}

/// Gradient magnitude and orientation bin of row `y` (the first `mrow.len()` columns), the plane
/// of largest magnitude per pixel (reflect-101 borders); `row(p, y)` is row `y` of plane `p`.
#[allow(clippy::too_many_arguments)]
fn gradient_row<'r>(
    isa: Isa,
    n_planes: usize,
    row: impl Fn(usize, usize) -> &'r [f32],
    w: usize,
    h: usize,
    y: usize,
    mrow: &mut [f32],
    brow: &mut [u8],
    best: &mut [[f32; 3]],
) {
    let edges = bin_edges();
    let yu = if y == 0 { 1.min(h - 1) } else { y - 1 };
    let yd = if y + 1 == h { y.saturating_sub(1) } else { y + 1 };
    let gw = mrow.len();
    if n_planes == 1 {
        // one plane (mosaic, grey): the interior through the kernels, the border columns here
        let (up, mid, dn) = (row(0, yu), row(0, y), row(0, yd));
        let one = |x: usize, xl: usize, xr: usize| {
            let gx = (mid[xr] - mid[xl]) * 0.5;
            let gy = (dn[x] - up[x]) * 0.5;
            ((gx * gx + gy * gy).sqrt(), orient_bin(gx, gy, &edges))
        };
        (mrow[0], brow[0]) = one(0, 1.min(w - 1), 1.min(w - 1));
        let inner_end = gw.min(w - 1);
        if inner_end > 1 {
            kernels::grad_row(
                isa,
                up,
                mid,
                dn,
                &edges,
                &mut mrow[..inner_end],
                &mut brow[..inner_end],
            );
        }
        if gw == w && w > 1 {
            (mrow[w - 1], brow[w - 1]) = one(w - 1, w - 2, w - 2);
        }
        return;
    }
    for pi in 0..n_planes {
        let (up, mid, dn) = (row(pi, yu), row(pi, y), row(pi, yd));
        let put = |x: usize, xl: usize, xr: usize, best: &mut [f32; 3]| {
            let gx = (mid[xr] - mid[xl]) * 0.5;
            let gy = (dn[x] - up[x]) * 0.5;
            let m2 = gx * gx + gy * gy;
            if pi == 0 || m2 > best[0] {
                *best = [m2, gx, gy];
            }
        };
        put(0, 1.min(w - 1), 1.min(w - 1), &mut best[0]);
        let inner_end = gw.min(w - 1);
        for (x, b) in best.iter_mut().enumerate().take(inner_end).skip(1) {
            put(x, x - 1, x + 1, b);
        }
        if gw == w && w > 1 {
            put(w - 1, w - 2, w - 2, &mut best[w - 1]);
        }
    }
    for ((m, b), s) in mrow.iter_mut().zip(brow.iter_mut()).zip(best.iter()) {
        *m = s[0].sqrt();
        *b = orient_bin(s[1], s[2], &edges);
    }
}

/// The ten channels of `input` before the output smoothing (what the pyramid resamples).
///
/// One pass over bands of 16 block rows in parallel: per band, the input
/// rows (scaled), the gradient of the band's rows and of the normalisation's halo, the
/// normalisation row by row, the block sums and the colour; every value is the arithmetic of
/// the module docs in the same order for any band split and thread count.
pub fn channels_unsmoothed(input: &ChannelInput, spec: &ChannelSpec) -> Result<Channels, ChannelsError> {
    channels_unsmoothed_on(crate::kernels::isa(), input, spec)
}

/// [`channels_unsmoothed`] on the kernel path `isa`.
fn channels_unsmoothed_on(
    isa: Isa,
    input: &ChannelInput,
    spec: &ChannelSpec,
) -> Result<Channels, ChannelsError> {
    const S: f32 = 1.0 / 255.0;
    let (w, h) = input.dimensions();
    if w < SHRINK || h < SHRINK {
        return Err(ChannelsError::TooSmall {
            width: w,
            height: h,
            min_width: SHRINK,
            min_height: SHRINK,
        });
    }
    if let ChannelInput::Mosaic { .. } = input {
        if w % 2 != 0 || h % 2 != 0 {
            return Err(ChannelsError::OddMosaic { width: w, height: h });
        }
    }
    let o = spec.options();
    // The planes as read: a float mosaic or grey image itself, scaled while read; otherwise (and
    // with input smoothing) owned planes already scaled.
    let owned: Vec<Vec<f32>>;
    let (src, scale): (Vec<ImageView<'_, f32>>, f32) = match input {
        ChannelInput::Mosaic { image: v, .. } | ChannelInput::GreyF32(v) if o.input_smooth <= 0.0 => {
            (vec![*v], S)
        }
        _ => {
            let (mut planes, step) = planes_of(input);
            if o.input_smooth > 0.0 {
                let mut tmp = Vec::new();
                for p in planes.iter_mut() {
                    triangle_filter_on(isa, p, w, h, o.input_smooth, step, &mut tmp);
                    std::mem::swap(p, &mut tmp);
                }
            }
            owned = planes;
            let views = owned
                .iter()
                .map(|p| ImageView::new(p, w, h, w).expect("a plane holds w · h values"))
                .collect();
            (views, 1.0)
        }
    };
    let np = src.len();
    let (cw, ch) = (w / SHRINK, h / SHRINK);
    let n = cw * ch;
    // Gradients only over the aggregated area; the normalisation filters that `gw x gh` field.
    let (gw, gh) = (cw * SHRINK, ch * SHRINK);
    let norm = Triangle::new(gw, gh, o.norm_radius, 1);
    let inv = 1.0 / (SHRINK * SHRINK) as f32;
    let colour = ColourSites::of(input);
    let bands: Vec<(usize, Vec<f32>)> = (0..ch)
        .step_by(BLOCK_ROWS_PER_TASK)
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|by0| {
            let by1 = (by0 + BLOCK_ROWS_PER_TASK).min(ch);
            let nb = by1 - by0;
            let (y0, y1) = (by0 * SHRINK, by1 * SHRINK);
            // magnitude rows the band's normalisation reads, and the input rows of those
            let (mlo, mhi) = match &norm {
                Some(t) => (y0..y1)
                    .flat_map(|y| t.rows_of(y).iter().copied())
                    .fold((y0, y1), |(lo, hi), r| (lo.min(r), hi.max(r + 1))),
                None => (y0, y1),
            };
            let (ilo, ihi) = (mlo.saturating_sub(1), (mhi + 1).min(h));
            // every value written: L, U, V by the colour, the rest by the aggregation
            let mut out = pool::overwritten(N_CHANNELS * nb * cw);
            SCRATCH.with_borrow_mut(|sc| {
                let Scratch {
                    inp,
                    mag,
                    bin,
                    best,
                    tmp,
                    norm: nrow,
                    v,
                    luv,
                } = sc;
                scaled_rows(&src, scale, w, ilo, ihi, inp);
                let ni = ihi - ilo;
                let row = |p: usize, y: usize| &inp[(p * ni + y - ilo) * w..(p * ni + y - ilo + 1) * w];
                let nm = mhi - mlo;
                mag.resize(nm * gw, 0.0);
                bin.resize(nm * gw, 0);
                best.resize(if np > 1 { gw } else { 0 }, [0.0; 3]);
                for y in mlo..mhi {
                    let r = (y - mlo) * gw..(y - mlo + 1) * gw;
                    gradient_row(isa, np, row, w, h, y, &mut mag[r.clone()], &mut bin[r], best);
                }
                tmp.resize(gw, 0.0);
                nrow.resize(gw, 0.0);
                v.resize(SHRINK * gw, 0.0);
                for by in by0..by1 {
                    let j = by - by0;
                    let first = (by * SHRINK - mlo) * gw;
                    let vals: &[f32] = match &norm {
                        Some(t) => {
                            for r in 0..SHRINK {
                                let y = by * SHRINK + r;
                                let mrow = |sy: usize| &mag[(sy - mlo) * gw..(sy - mlo + 1) * gw];
                                t.row(isa, y, mrow, tmp, nrow);
                                kernels::normalise(
                                    isa,
                                    mrow(y),
                                    nrow,
                                    o.norm_const,
                                    &mut v[r * gw..(r + 1) * gw],
                                );
                            }
                            v
                        }
                        None => &mag[first..first + SHRINK * gw],
                    };
                    kernels::aggregate(
                        isa,
                        vals,
                        &bin[first..first + SHRINK * gw],
                        gw,
                        inv,
                        &mut out[(MAG_CHANNEL * nb + j) * cw..],
                        nb * cw,
                    );
                    colour.block_row(isa, np, row, cw, by, &mut out[j * cw..], nb * cw, luv);
                }
            });
            (by0, out)
        })
        .collect();
    // every value written: the bands cover every block row of every channel
    let mut out = Channels {
        width: cw,
        height: ch,
        data: pool::overwritten(N_CHANNELS * n),
    };
    for (by0, band) in bands {
        let len = band.len() / N_CHANNELS;
        for (c, part) in band.chunks_exact(len).enumerate() {
            out.data[c * n + by0 * cw..c * n + by0 * cw + len].copy_from_slice(part);
        }
        pool::give(band);
    }
    Ok(out)
}

/// Where the colour of a block comes from: the 2x2 super-pixels of a mosaic (the offsets of R,
/// the two Gs and B within one), or every pixel.
#[derive(Clone, Copy)]
enum ColourSites {
    Mosaic {
        r: (usize, usize),
        g: [(usize, usize); 2],
        b: (usize, usize),
    },
    Pixels,
}

impl ColourSites {
    fn of(input: &ChannelInput) -> Self {
        let ChannelInput::Mosaic { cfa, .. } = input else {
            return ColourSites::Pixels;
        };
        let (mut r, mut b, mut g, mut ng) = ((0, 0), (0, 0), [(0, 0); 2], 0);
        for (dx, dy) in [(0usize, 0usize), (1, 0), (0, 1), (1, 1)] {
            match cfa.colour_at(dx, dy) {
                Colour::Red => r = (dx, dy),
                Colour::Blue => b = (dx, dy),
                Colour::Green => {
                    g[ng] = (dx, dy);
                    ng += 1;
                }
            }
        }
        ColourSites::Mosaic { r, g, b }
    }

    /// Block means of L, U, V along block row `by` (per 2x2 super-pixel on a mosaic, per pixel
    /// otherwise) into `out[k·stride + bx]`; `row(p, y)` is row `y` of plane `p` (one plane, or R,
    /// G, B), scaled to `[0, 1]`. The colours of the block row are gathered into `buf`, converted
    /// by the LUV kernel, then summed per block in the oracle's order (super-pixel or pixel rows,
    /// then left to right, from 0).
    #[allow(clippy::too_many_arguments)]
    fn block_row<'r>(
        self,
        isa: Isa,
        n_planes: usize,
        row: impl Fn(usize, usize) -> &'r [f32],
        cw: usize,
        by: usize,
        out: &mut [f32],
        stride: usize,
        buf: &mut Vec<f32>,
    ) {
        // `rows` rows of `per` colours each (super-pixels or pixels), `side` of them per block
        let (rows, per, side) = match self {
            ColourSites::Mosaic { .. } => (SHRINK / 2, cw * SHRINK / 2, SHRINK / 2),
            ColourSites::Pixels => (SHRINK, cw * SHRINK, SHRINK),
        };
        let m = rows * per;
        buf.resize(6 * m, 0.0);
        let (rgb, luv) = buf.split_at_mut(3 * m);
        let (r, rest) = rgb.split_at_mut(m);
        let (g, b) = rest.split_at_mut(m);
        match self {
            ColourSites::Mosaic { r: ro, g: go, b: bo } => {
                // each colour's site in a super-pixel [top-left, top-right, bottom-left,
                // bottom-right]
                let site = |(dx, dy): (usize, usize)| dy * 2 + dx;
                let (kr, kg0, kg1, kb) = (site(ro), site(go[0]), site(go[1]), site(bo));
                for sy in 0..rows {
                    let y0 = by * SHRINK + 2 * sy;
                    let (top, bot) = (&row(0, y0)[..2 * per], &row(0, y0 + 1)[..2 * per]);
                    let span = sy * per..(sy + 1) * per;
                    let sites = top.chunks_exact(2).zip(bot.chunks_exact(2));
                    let dst = r[span.clone()]
                        .iter_mut()
                        .zip(&mut g[span.clone()])
                        .zip(&mut b[span]);
                    for ((t, d), ((ri, gi), bi)) in sites.zip(dst) {
                        let s = [t[0], t[1], d[0], d[1]];
                        *ri = s[kr];
                        *gi = 0.5 * (s[kg0] + s[kg1]);
                        *bi = s[kb];
                    }
                }
            }
            ColourSites::Pixels => {
                for j in 0..rows {
                    let y = by * SHRINK + j;
                    let span = j * per..(j + 1) * per;
                    let p = |k: usize| &row(k.min(n_planes - 1), y)[..per];
                    r[span.clone()].copy_from_slice(p(0));
                    g[span.clone()].copy_from_slice(p(1));
                    b[span].copy_from_slice(p(2));
                }
            }
        }
        let (l, rest) = luv.split_at_mut(m);
        let (u, v) = rest.split_at_mut(m);
        kernels::luv_row(isa, [r, g, b], [&mut *l, &mut *u, &mut *v]);
        let inv = 1.0 / (side * side) as f32;
        for (k, c) in [&*l, &*u, &*v].into_iter().enumerate() {
            let o = &mut out[k * stride..k * stride + cw];
            if let ColourSites::Mosaic { .. } = self {
                // 2x2 super-pixels per block: the two rows' pairs, from 0
                let (c0, c1) = c.split_at(per);
                for ((o, a), b) in o.iter_mut().zip(c0.chunks_exact(2)).zip(c1.chunks_exact(2)) {
                    *o = (0.0 + a[0] + a[1] + b[0] + b[1]) * inv;
                }
                continue;
            }
            for (bx, o) in o.iter_mut().enumerate() {
                let mut acc = 0.0f32;
                for j in 0..rows {
                    for x in bx * side..(bx + 1) * side {
                        acc += c[j * per + x];
                    }
                }
                *o = acc * inv;
            }
        }
    }
}

/// The ten aggregated, smoothed channels of `input` (see the module docs).
pub fn channels(input: &ChannelInput, spec: &ChannelSpec) -> Result<Channels, ChannelsError> {
    let mut c = channels_unsmoothed(input, spec)?;
    smooth_channels(&mut c, spec.options().output_smooth);
    Ok(c)
}
