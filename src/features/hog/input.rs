//! What HOG reads: the input kinds, their gamma-corrected planes, and the checks on them.

use rayon::prelude::*;

use super::types::Planes;
use super::{kernels, HogError, HogSpec, UNIT_RANGE};
use crate::image::{Image, ImageView};

/// What HOG is computed from.
#[derive(Debug, Clone, Copy)]
pub enum HogInput<'a> {
    /// 8-bit grey (exactly OpenCV's path).
    GreyU8(ImageView<'a, u8>),
    /// 16-bit grey, scaled by 255 / `max_value`.
    GreyU16 {
        /// Pixels.
        image: ImageView<'a, u16>,
        /// Value that maps to 255.
        max_value: u16,
    },
    /// Float grey in 8-bit units (0..=255).
    GreyF32(ImageView<'a, f32>),
    /// 8-bit RGB (R, G, B order); OpenCV's per-pixel max-magnitude channel.
    Rgb8(ImageView<'a, [u8; 3]>),
    /// Float colour planes (R, G, B) in 8-bit units; OpenCV's max-magnitude channel.
    ColourF32([ImageView<'a, f32>; 3]),
    /// A Bayer mosaic, black-subtracted and scaled to 0..=255 (see
    /// [`mosaic_from_raw`](super::mosaic_from_raw)); gradients use same-colour taps two pixels
    /// apart.
    Mosaic(ImageView<'a, f32>),
}

impl HogInput<'_> {
    /// (width, height).
    pub fn dimensions(&self) -> (usize, usize) {
        match self {
            HogInput::GreyU8(v) => (v.width(), v.height()),
            HogInput::GreyU16 { image, .. } => (image.width(), image.height()),
            HogInput::GreyF32(v) | HogInput::Mosaic(v) => (v.width(), v.height()),
            HogInput::Rgb8(v) => (v.width(), v.height()),
            HogInput::ColourF32(p) => (p[0].width(), p[0].height()),
        }
    }
}

/// [`Planes`] that own their pixels.
pub(super) struct OwnedPlanes {
    planes: Vec<Image<f32>>,
    tap: usize,
}

impl OwnedPlanes {
    pub(super) fn view(&self) -> Planes<'_> {
        Planes {
            width: self.planes[0].width(),
            height: self.planes[0].height(),
            planes: self.planes.iter().map(|p| p.view()).collect(),
            tap: self.tap,
        }
    }
}

/// Gamma-corrected planes handed to
/// [`cell_grid_from_gamma_planes`](super::cell_grid_from_gamma_planes): every sample is already
/// `√max(v, 0)` (`max(v, 0)` when the spec's `gamma_correction` is off), as [`gamma_in_place`]
/// leaves it.
#[derive(Debug, Clone, Copy)]
pub enum GammaPlanes<'a> {
    /// One grey plane.
    Grey(ImageView<'a, f32>),
    /// A Bayer mosaic (even size).
    Mosaic(ImageView<'a, f32>),
    /// Three colour planes in OpenCV's B, G, R order (ties resolve towards B).
    Colour([ImageView<'a, f32>; 3]),
}

/// `ImageTooSmall` unless a `w x h` image holds one window.
pub(super) fn check_fits(spec: &HogSpec, w: usize, h: usize) -> Result<(), HogError> {
    if w < spec.win_width() || h < spec.win_height() {
        return Err(HogError::ImageTooSmall {
            width: w,
            height: h,
            win_width: spec.win_width(),
            win_height: spec.win_height(),
        });
    }
    Ok(())
}

pub(super) fn planes_from_input(spec: &HogSpec, input: &HogInput) -> Result<OwnedPlanes, HogError> {
    let (w, h) = input.dimensions();
    check_fits(spec, w, h)?;
    let gamma = spec.opts.gamma_correction;
    let g = move |v: f32| if gamma { v.sqrt() } else { v };
    let mut tap = 1;
    let planes = match input {
        HogInput::GreyU8(v) => {
            let lut: Vec<f32> = (0..256).map(|i| g(i as f32)).collect();
            vec![plane_map(*v, |p| lut[p as usize])]
        }
        HogInput::GreyU16 { image, max_value } => {
            if *max_value == 0 {
                return Err(HogError::BadMaxValue(0));
            }
            let s = UNIT_RANGE / *max_value as f32;
            vec![plane_map(*image, |p| g(p as f32 * s))]
        }
        HogInput::GreyF32(v) => vec![gamma_plane(*v, gamma)],
        HogInput::Mosaic(v) => {
            if w % 2 != 0 || h % 2 != 0 {
                return Err(HogError::OddMosaic { width: w, height: h });
            }
            tap = spec.opts.mosaic_taps.distance();
            vec![gamma_plane(*v, gamma)]
        }
        HogInput::ColourF32(p) => {
            for q in &p[1..] {
                if (q.width(), q.height()) != (w, h) {
                    return Err(HogError::PlaneSize {
                        width: q.width(),
                        height: q.height(),
                        want_width: w,
                        want_height: h,
                    });
                }
            }
            (0..3).map(|c| plane_map(p[2 - c], |v| g(v.max(0.0)))).collect()
        }
        HogInput::Rgb8(v) => {
            let lut: Vec<f32> = (0..256).map(|i| g(i as f32)).collect();
            // OpenCV order B, G, R: ties resolve towards B.
            (0..3)
                .map(|c| plane_map(*v, |p: [u8; 3]| lut[p[2 - c] as usize]))
                .collect()
        }
    };
    Ok(OwnedPlanes { planes, tap })
}

fn gamma_plane(v: ImageView<'_, f32>, gamma: bool) -> Image<f32> {
    let mut out = Image::new(0, 0);
    gamma_plane_into(v, gamma, &mut out);
    out
}

/// `dst` = `√max(v, 0)` (or `max(v, 0)` without gamma) of a float plane, rows in parallel,
/// vectorised; `dst`'s allocation is reused.
pub fn gamma_plane_into(v: ImageView<'_, f32>, gamma: bool, dst: &mut Image<f32>) {
    let w = v.width();
    dst.reshape(w, v.height());
    dst.as_mut_slice()
        .par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            row.copy_from_slice(v.row(y));
            gamma_in_place(row, gamma)
        });
}

/// `v ← √max(v, 0)` (or `max(v, 0)` without gamma) for every sample of `row` — HOG's gamma
/// correction, built for the process's kernel path ([`crate::kernels::isa`]; vector square roots
/// are IEEE square roots, the same bits as scalar code).
pub fn gamma_in_place(row: &mut [f32], gamma: bool) {
    kernels::gamma_in_place(crate::kernels::isa(), row, gamma)
}

fn plane_map<P: Copy + Sync>(v: ImageView<'_, P>, f: impl Fn(P) -> f32 + Sync) -> Image<f32> {
    let (w, h) = (v.width(), v.height());
    let mut out = Image::<f32>::new(w, h);
    out.as_mut_slice()
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(y, row)| {
            for (o, &p) in row.iter_mut().zip(v.row(y)) {
                *o = f(p);
            }
        });
    let _ = h;
    out
}

/// Validated [`Planes`] of gamma-corrected input.
pub(super) fn planes_of<'a>(spec: &HogSpec, planes: &GammaPlanes<'a>) -> Result<Planes<'a>, HogError> {
    let (views, tap) = match planes {
        GammaPlanes::Grey(v) => (vec![*v], 1),
        GammaPlanes::Mosaic(v) => (vec![*v], spec.opts.mosaic_taps.distance()),
        GammaPlanes::Colour(p) => (p.to_vec(), 1),
    };
    let (w, h) = (views[0].width(), views[0].height());
    check_fits(spec, w, h)?;
    if matches!(planes, GammaPlanes::Mosaic(_)) && (w % 2 != 0 || h % 2 != 0) {
        return Err(HogError::OddMosaic { width: w, height: h });
    }
    if let Some(q) = views.iter().find(|q| (q.width(), q.height()) != (w, h)) {
        return Err(HogError::PlaneSize {
            width: q.width(),
            height: q.height(),
            want_width: w,
            want_height: h,
        });
    }
    Ok(Planes {
        width: w,
        height: h,
        planes: views,
        tap,
    })
}
