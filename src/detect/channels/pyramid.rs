//! The fast feature pyramid of aggregated channels (Dollár et al. 2014, §4; `chnsPyramid`).
//!
//! Scales `s_i = u · 2^(−i/n)` for `i = 0, 1, …` while the image still holds one window (`u` the
//! upsampling, `n` levels per octave). Every `(a + 1)`-th level (`a` approximated levels between
//! exact ones, 7 by default: one exact level per octave) is computed exactly: the input is
//! resized to `4·round(s·W/4) x 4·round(s·H/4)` (CFA-preserving on a mosaic) and its channels
//! computed. Every other level is resampled (bilinear) from the unsmoothed channels of the
//! nearest exact level `R` (nearest in level index, as Dollár) and scaled per channel type by the
//! power law (both in one pass: the detector's one bilinear resize with a factor per plane,
//! [`crate::resize::resize_planes_scaled`])
//!
//! ```text
//! C_s ≈ resample(C_R) · (s / s_R)^(−λ_Ω)
//! ```
//!
//! with `λ` for the colour, magnitude and orientation channels ([`PyramidOptions::lambdas`];
//! colour channels do not change with scale, `λ = 0`; gradient channels lose energy as an image
//! is downsampled, `λ > 0`). Every level is then smoothed ([`super::smooth_channels`]). The real
//! scale of a level is per axis (`scale_x`, `scale_y`), the size rounding being per axis.
//!
//! # Where we differ from Dollár
//! No padding of the channel maps (Dollár pads by `(modelDsPad − modelDs)/2`): windows lie inside
//! the image. The default λ are Dollár's published INRIA values until we measure our own
//! ([`PyramidOptions::default`]).

use rayon::prelude::*;

use crate::image::{Image, ImageView};
use crate::resize::{resize_bilinear, resize_mosaic, resize_planes_scaled_with};

use crate::kernels::Isa;

use super::{
    channels_unsmoothed_on, smooth_channels_on, ChannelInput, ChannelSpec, Channels, ChannelsError,
    MAG_CHANNEL, N_CHANNELS, SHRINK,
};

/// Pyramid options, named after Dollár's `chnsPyramid`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PyramidOptions {
    /// Levels per octave (`nPerOct`).
    pub per_octave: usize,
    /// Approximated levels between exact ones (`nApprox`; 0 = every level exact).
    pub approx: usize,
    /// Power-law exponents λ of the colour, magnitude and orientation channels.
    pub lambdas: [f32; 3],
    /// Scale of the first level (2 finds people half as tall as the window).
    pub upsample: f64,
    /// Smallest level size in pixels: the window (width, height).
    pub min_size: (usize, usize),
    /// At most this many levels.
    pub max_levels: usize,
}

impl Default for PyramidOptions {
    /// Dollár's: 8 levels per octave, 7 approximated, λ = (0, 0.11, 0.11) (his INRIA values),
    /// no upsampling, a 64x128 window.
    fn default() -> Self {
        Self {
            per_octave: 8,
            approx: 7,
            lambdas: [0.0, 0.11, 0.11],
            upsample: 1.0,
            min_size: (64, 128),
            max_levels: 64,
        }
    }
}

impl PyramidOptions {
    fn check(&self) -> Result<(), ChannelsError> {
        let bad = |name, value: String, allowed| Err(ChannelsError::BadOption { name, value, allowed });
        if self.per_octave == 0 || self.per_octave > 64 {
            return bad("per_octave", self.per_octave.to_string(), "1..=64");
        }
        if !(self.upsample.is_finite() && (0.25..=8.0).contains(&self.upsample)) {
            return bad("upsample", self.upsample.to_string(), "0.25..=8");
        }
        if self.lambdas.iter().any(|l| !l.is_finite() || l.abs() > 4.0) {
            return bad("lambdas", format!("{:?}", self.lambdas), "finite, |λ| ≤ 4");
        }
        if self.min_size.0 < SHRINK || self.min_size.1 < SHRINK {
            return bad("min_size", format!("{:?}", self.min_size), "at least one block");
        }
        Ok(())
    }

    /// The per-channel exponent of channel `c`.
    pub fn lambda_of(&self, c: usize) -> f32 {
        match c {
            0..MAG_CHANNEL => self.lambdas[0],
            MAG_CHANNEL => self.lambdas[1],
            _ => self.lambdas[2],
        }
    }
}

/// One pyramid level.
#[derive(Debug, Clone)]
pub struct Level {
    /// Nominal scale `s_i` (level pixels per input pixel).
    pub scale: f64,
    /// Real horizontal scale (level width / input width).
    pub scale_x: f64,
    /// Real vertical scale.
    pub scale_y: f64,
    /// Computed exactly (not approximated).
    pub exact: bool,
    /// The smoothed channels.
    pub channels: Channels,
}

/// The levels, largest first.
#[derive(Debug, Clone, Default)]
pub struct ChannelPyramid {
    /// Levels.
    pub levels: Vec<Level>,
}

/// Owned resized input.
enum Resized {
    Mosaic(Image<f32>),
    Grey(Image<f32>),
    Rgb([Image<f32>; 3]),
}

fn resize_input(input: &ChannelInput, w: usize, h: usize) -> Result<Resized, ChannelsError> {
    let (iw, ih) = input.dimensions();
    let plane = |v: ImageView<'_, f32>| -> Result<Image<f32>, ChannelsError> {
        let mut d = Image::new(0, 0);
        if (iw, ih) == (w, h) {
            return Ok(v.to_image());
        }
        resize_bilinear(v, w, h, &mut d)?;
        Ok(d)
    };
    Ok(match input {
        ChannelInput::Mosaic { image, .. } => {
            let mut d = Image::new(0, 0);
            if (iw, ih) == (w, h) {
                d = image.to_image();
            } else {
                resize_mosaic(*image, w, h, &mut d)?;
            }
            Resized::Mosaic(d)
        }
        ChannelInput::GreyF32(v) => Resized::Grey(plane(*v)?),
        ChannelInput::GreyU8(v) => Resized::Grey(plane(v.to_image().map(|p| p as f32).view())?),
        ChannelInput::Rgb8(v) => {
            let img = v.to_image();
            let p = |k: usize| plane(img.map(|p| p[k] as f32).view());
            Resized::Rgb([p(0)?, p(1)?, p(2)?])
        }
        ChannelInput::RgbF32(ps) => Resized::Rgb([plane(ps[0])?, plane(ps[1])?, plane(ps[2])?]),
    })
}

/// The unsmoothed channels of `input` resized to `w x h` pixels (the input itself, not a copy,
/// at its own size).
fn resized_channels(
    isa: Isa,
    input: &ChannelInput,
    w: usize,
    h: usize,
    spec: &ChannelSpec,
) -> Result<Channels, ChannelsError> {
    if input.dimensions() == (w, h) {
        return channels_unsmoothed_on(isa, input, spec);
    }
    match (resize_input(input, w, h)?, input) {
        (Resized::Mosaic(m), ChannelInput::Mosaic { cfa, .. }) => channels_unsmoothed_on(
            isa,
            &ChannelInput::Mosaic {
                image: m.view(),
                cfa: *cfa,
            },
            spec,
        ),
        (Resized::Grey(g), _) => channels_unsmoothed_on(isa, &ChannelInput::GreyF32(g.view()), spec),
        (Resized::Rgb(p), _) => channels_unsmoothed_on(
            isa,
            &ChannelInput::RgbF32([p[0].view(), p[1].view(), p[2].view()]),
            spec,
        ),
        (Resized::Mosaic(_), _) => unreachable!("a mosaic is resized only from a mosaic"),
    }
}

/// Resample every channel of `src` to `w x h` blocks and multiply channel `c` by `ratio(c)`: the
/// detector's one bilinear resize with a factor per plane
/// ([`crate::resize::resize_planes_scaled`], the ten planes in parallel), on kernel
/// path `isa`.
fn resample_channels(
    isa: Isa,
    src: &Channels,
    w: usize,
    h: usize,
    ratio: impl Fn(usize) -> f32,
) -> Result<Channels, ChannelsError> {
    let k: [f32; N_CHANNELS] = std::array::from_fn(ratio);
    let mut out = Channels::zeros(w, h);
    let (sw, sh) = (src.width(), src.height());
    resize_planes_scaled_with(&src.data, (sw, sh), (w, h), &mut out.data, &k, isa)?;
    Ok(out)
}

/// The channel pyramid of `input` (see the module docs).
pub fn pyramid(
    input: &ChannelInput,
    spec: &ChannelSpec,
    opts: &PyramidOptions,
) -> Result<ChannelPyramid, ChannelsError> {
    pyramid_on(crate::kernels::isa(), input, spec, opts)
}

/// [`pyramid()`] on the channel kernels' path `isa` (the resizes run on the process's path).
pub(super) fn pyramid_on(
    isa: Isa,
    input: &ChannelInput,
    spec: &ChannelSpec,
    opts: &PyramidOptions,
) -> Result<ChannelPyramid, ChannelsError> {
    opts.check()?;
    let (w, h) = input.dimensions();
    let (mw, mh) = opts.min_size;
    let fit = (w as f64 / mw as f64).min(h as f64 / mh as f64) * opts.upsample;
    if fit < 1.0 {
        return Err(ChannelsError::TooSmall {
            width: w,
            height: h,
            min_width: (mw as f64 / opts.upsample).ceil() as usize,
            min_height: (mh as f64 / opts.upsample).ceil() as usize,
        });
    }
    let n = ((opts.per_octave as f64 * fit.log2()).floor() as usize + 1).min(opts.max_levels.max(1));
    // Nominal scales and the block sizes of each level.
    let mut plan = Vec::with_capacity(n);
    for i in 0..n {
        let s = opts.upsample * 2f64.powf(-(i as f64) / opts.per_octave as f64);
        let lw = ((w as f64 * s / SHRINK as f64).round() as usize).max(1) * SHRINK;
        let lh = ((h as f64 * s / SHRINK as f64).round() as usize).max(1) * SHRINK;
        if lw < mw || lh < mh {
            break;
        }
        plan.push((s, lw, lh));
    }
    let n = plan.len();
    let step = opts.approx + 1;
    let exact: Vec<usize> = (0..n).step_by(step).collect();
    // Exact levels one after the other (each parallel inside), then every approximated level
    // resampled from the unsmoothed channels of its nearest exact level, levels in parallel: each
    // level is the same arithmetic for any thread count.
    let raw: Vec<Channels> = exact
        .iter()
        .map(|&i| resized_channels(isa, input, plan[i].1, plan[i].2, spec))
        .collect::<Result<_, _>>()?;
    let level = |i: usize, channels: Channels| {
        let (s, lw, lh) = plan[i];
        Level {
            scale: s,
            scale_x: lw as f64 / w as f64,
            scale_y: lh as f64 / h as f64,
            exact: i.is_multiple_of(step),
            channels,
        }
    };
    let approximated: Vec<Option<Level>> = (0..n)
        .into_par_iter()
        .map(|i| -> Result<Option<Level>, ChannelsError> {
            if i % step == 0 {
                return Ok(None);
            }
            let (s, lw, lh) = plan[i];
            // nearest exact level in index (ties: the larger image, as Dollár's split)
            let r = exact
                .iter()
                .copied()
                .min_by_key(|&e| (e.abs_diff(i), e > i))
                .expect("level 0 is exact");
            let rel = (s / plan[r].0) as f32;
            let c = resample_channels(isa, &raw[r / step], lw / SHRINK, lh / SHRINK, |c| {
                rel.powf(-opts.lambda_of(c))
            })?;
            Ok(Some(level(i, c)))
        })
        .collect::<Result<_, _>>()?;
    // the exact levels' channels move into their levels (no copy)
    let mut raw = raw.into_iter();
    let mut levels: Vec<Level> = approximated
        .into_iter()
        .enumerate()
        .map(|(i, l)| l.unwrap_or_else(|| level(i, raw.next().expect("one per exact level"))))
        .collect();
    // Approximated levels must read the unsmoothed exact channels: smooth only now.
    let r = spec.options().output_smooth;
    levels
        .par_iter_mut()
        .for_each(|l| smooth_channels_on(isa, &mut l.channels, r));
    Ok(ChannelPyramid { levels })
}

/// Measure the power-law exponents λ of the colour, magnitude and orientation channels on
/// `images` as Dollár's `chnsScaling` does: each image is resized by `s_k = 2^(−k/per_octave)`,
/// `k = 1..=per_octave·octaves` (CFA-preserving on a mosaic, sizes rounded to blocks), and for each
/// channel type the mean of its (unsmoothed) channels is divided by the mean at `s = 1`; the ratios
/// are averaged over the images where both are positive, and λ is minus the least-squares slope of
/// `log₂ ratio` against `log₂ s`. Scales whose image falls below one block are skipped.
pub fn measure_lambdas(
    images: &[ChannelInput],
    spec: &ChannelSpec,
    per_octave: usize,
    octaves: usize,
) -> Result<[f32; 3], ChannelsError> {
    let n = per_octave.max(1) * octaves.max(1);
    let means = |c: &Channels| -> [f64; 3] {
        let mut m = [0.0f64; 3];
        let mut cnt = [0usize; 3];
        for ch in 0..N_CHANNELS {
            let t = match ch {
                0..MAG_CHANNEL => 0,
                MAG_CHANNEL => 1,
                _ => 2,
            };
            m[t] += c.plane(ch).iter().map(|&v| v as f64).sum::<f64>();
            cnt[t] += c.plane(ch).len();
        }
        std::array::from_fn(|t| m[t] / cnt[t].max(1) as f64)
    };
    // sums of ratios and counts per scale and type
    let mut sum = vec![[0.0f64; 3]; n];
    let mut cnt = vec![[0usize; 3]; n];
    for img in images {
        let (w, h) = img.dimensions();
        let isa = crate::kernels::isa();
        let base = means(&channels_unsmoothed_on(isa, img, spec)?);
        for k in 1..=n {
            let s = 2f64.powf(-(k as f64) / per_octave as f64);
            let lw = (w as f64 * s / SHRINK as f64).round() as usize * SHRINK;
            let lh = (h as f64 * s / SHRINK as f64).round() as usize * SHRINK;
            if lw < SHRINK || lh < SHRINK {
                continue;
            }
            let m = means(&resized_channels(isa, img, lw, lh, spec)?);
            for t in 0..3 {
                if base[t] > 0.0 && m[t] > 0.0 {
                    sum[k - 1][t] += m[t] / base[t];
                    cnt[k - 1][t] += 1;
                }
            }
        }
    }
    Ok(std::array::from_fn(|t| {
        let pts: Vec<(f64, f64)> = (0..n)
            .filter(|&k| cnt[k][t] > 0)
            .map(|k| {
                (
                    -((k + 1) as f64) / per_octave as f64,
                    (sum[k][t] / cnt[k][t] as f64).log2(),
                )
            })
            .collect();
        if pts.len() < 2 {
            return 0.0;
        }
        let np = pts.len() as f64;
        let (mx, my) = (
            pts.iter().map(|p| p.0).sum::<f64>() / np,
            pts.iter().map(|p| p.1).sum::<f64>() / np,
        );
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        (-(sxy / sxx)) as f32
    }))
}
