//! The input's linear planes (8-bit units, no gamma) from which the pyramid's levels are resized.

use crate::features::hog::{gamma_in_place, HogInput};
use crate::image::{Image, ImageView};

/// Linear planes of the input (8-bit units, no gamma) from which levels are resized.
pub(super) enum Planes<'a> {
    Grey(Plane<'a>),
    Colour([Plane<'a>; 3]),
    Mosaic(Plane<'a>),
}

/// The input's linear planes and whether they hold 8-bit integers (u8 grey or RGB input): then
/// every resized level is rounded to integers, as OpenCV keeps an 8-bit image's pyramid in 8 bits.
pub(super) struct Linear<'a> {
    pub(super) planes: Planes<'a>,
    pub(super) eight_bit: bool,
    /// The planes are a magnified frame in buffers of the detector's pool.
    pub(super) pooled: bool,
}

impl Linear<'_> {
    /// The row operation of a resized level: rounding (8-bit input), then gamma.
    pub(super) fn level_row_op(&self, gamma: bool) -> impl Fn(&mut [f32]) + Sync + 'static {
        let round = self.eight_bit;
        move |row: &mut [f32]| {
            if round {
                round_in_place(row);
            }
            gamma_in_place(row, gamma)
        }
    }
}

/// Round every value to the nearest integer (halves away from zero, as OpenCV's
/// `saturate_cast<uchar>` rounds non-negative values).
pub(super) fn round_in_place(row: &mut [f32]) {
    for v in row {
        *v = v.round();
    }
}

/// A linear plane: converted from integer input, or the caller's f32 plane itself (no copy).
pub(super) enum Plane<'a> {
    Owned(Image<f32>),
    Borrowed(ImageView<'a, f32>),
}

impl Plane<'_> {
    pub(super) fn view(&self) -> ImageView<'_, f32> {
        match self {
            Plane::Owned(i) => i.view(),
            Plane::Borrowed(v) => *v,
        }
    }
}

pub(super) fn linear_from_input<'a>(input: &HogInput<'a>) -> Linear<'a> {
    use Plane::{Borrowed, Owned};
    let eight_bit = matches!(input, HogInput::GreyU8(_) | HogInput::Rgb8(_));
    let planes = match input {
        HogInput::GreyU8(v) => Planes::Grey(Owned(v.to_image().map(|p| p as f32))),
        HogInput::GreyU16 { image, max_value } => {
            let s = 255.0 / (*max_value).max(1) as f32;
            Planes::Grey(Owned(image.to_image().map(|p| p as f32 * s)))
        }
        HogInput::GreyF32(v) => Planes::Grey(Borrowed(*v)),
        HogInput::Mosaic(v) => Planes::Mosaic(Borrowed(*v)),
        HogInput::Rgb8(v) => {
            let img = v.to_image();
            Planes::Colour([0, 1, 2].map(|c| Owned(img.map(|p| p[c] as f32))))
        }
        HogInput::ColourF32(p) => Planes::Colour(p.map(Borrowed)),
    };
    Linear {
        planes,
        eight_bit,
        pooled: false,
    }
}
