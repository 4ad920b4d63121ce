//! Domain preparation: every training or evaluation image brought into the model's input domain
//! (colour, grey or mosaic), sampled from the sRGB image or through the reverse ISP to raw and back
//! (see the module docs of [`super`]), and the descriptors of its windows.
//!
//! Noise streams are seeded per image ([`image_seed`] of the pipeline's seed and the image's
//! index); negatives, their mirrors, the raw scenes and the training-only negatives add fixed
//! offsets to the index so that no two images share a stream.

use std::path::Path;

use super::error::TrainError;
use crate::detect::input::MosaicPrep;
use rand::Rng;

use crate::data::{load_raw_frame, raw_profile, RawInput};
use crate::detect::model::Domain;
use crate::features::hog::{block_grid, BlockGrid, Exec, HogInput, HogSpec, CELL_SIZE};
use crate::image::Image;
use crate::isp::grey::grey_from_rgb_u8;
use crate::isp::{
    raw_from_srgb, srgb_from_raw, CameraProfile, ForwardIspOptions, NoiseLevel, ReverseIspOptions,
};
use crate::raw::{Cfa, Colour};
use crate::resize::{resize_bilinear, resize_mosaic};

/// Offset of the 64x128 window inside the 96x160 INRIA crops, in cells.
const POS_WINDOW_CELL: usize = 16 / CELL_SIZE;
/// Noise-seed offset of negative images, so they never share a seed with a positive.
pub(super) const NEG_SEED_OFFSET: u64 = 1 << 32;
/// Added to a negative image's noise index for its mirror.
pub(super) const MIRROR_SEED_OFFSET: u64 = 1 << 31;
/// Added to [`NEG_SEED_OFFSET`] for the raw scenes.
pub(super) const RAW_SCENE_SEED_OFFSET: u64 = 1 << 30;
/// Added to [`NEG_SEED_OFFSET`] for the training-only negatives of [`Split::extra_train_neg`].
pub(super) const EXTRA_NEG_SEED_OFFSET: u64 = 1 << 29;

/// How an sRGB data image becomes a model's input (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum InputPipeline {
    /// sRGB sampled through the CFA (mosaic), OpenCV's grey, or the RGB itself: how the shipped
    /// models were trained.
    Sampled,
    /// Reverse ISP to a raw frame with optional eq. 24 noise; mosaic = the raw frame, colour and grey =
    /// the forward ISP's output.
    ReverseIsp {
        /// Noise level (`None`: clean raw).
        noise: Option<NoiseLevel>,
        /// Base seed of the noise; image `i` uses a seed derived from it and `i`.
        seed: u64,
    },
}

impl InputPipeline {
    /// Parse `sampled`, `clean`, `low`, `medium` or `high` (case-insensitive; `raw-` prefix
    /// allowed, so every [`InputPipeline::name`] parses back); `seed` is the noise base seed.
    pub fn parse(s: &str, seed: u64) -> Result<Self, String> {
        let t = s.trim().to_ascii_lowercase();
        let t = t.strip_prefix("raw-").unwrap_or(&t);
        Ok(match t {
            "sampled" => InputPipeline::Sampled,
            "clean" => InputPipeline::ReverseIsp { noise: None, seed },
            other => InputPipeline::ReverseIsp {
                noise: Some(
                    other
                        .parse::<NoiseLevel>()
                        .map_err(|_| format!("{s:?}: expected sampled, clean, low, medium or high"))?,
                ),
                seed,
            },
        })
    }

    /// Short name: `sampled`, `raw-clean`, `raw-low`, `raw-medium`, `raw-high`.
    pub fn name(&self) -> String {
        match self {
            InputPipeline::Sampled => "sampled".into(),
            InputPipeline::ReverseIsp { noise: None, .. } => "raw-clean".into(),
            InputPipeline::ReverseIsp { noise: Some(n), .. } => format!("raw-{}", n.name()),
        }
    }
}

/// The noise seed of image `index` under base seed `seed` (splitmix-style mixing, so neighbouring
/// indices get unrelated streams).
pub(super) fn image_seed(seed: u64, index: u64) -> u64 {
    let mut z = seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// An image in a model's input domain.
#[derive(Debug, Clone)]
pub enum DomainImage {
    /// RGB.
    Colour(Image<[u8; 3]>),
    /// Grey.
    Grey(Image<u8>),
    /// Mosaic in 8-bit units.
    Mosaic(Image<f32>),
}

impl DomainImage {
    /// From an RGB image (mosaics are cropped to even size and sampled through `cfa`).
    pub fn from_rgb(img: &Image<[u8; 3]>, domain: Domain, cfa: Cfa) -> Self {
        match domain {
            Domain::Colour => DomainImage::Colour(img.clone()),
            Domain::Grey => DomainImage::Grey(img.map(|p| {
                ((p[0] as u32 * 4899 + p[1] as u32 * 9617 + p[2] as u32 * 1868 + (1 << 13)) >> 14) as u8
            })),
            Domain::Mosaic => {
                let (w, h) = (img.width() & !1, img.height() & !1);
                DomainImage::Mosaic(Image::from_fn(w, h, |x, y| {
                    let p = img.get(x, y);
                    match cfa.colour_at(x, y) {
                        Colour::Red => p[0] as f32,
                        Colour::Green => p[1] as f32,
                        Colour::Blue => p[2] as f32,
                    }
                }))
            }
        }
    }
    /// From an RGB image through `pipeline`; `index` picks the image's noise stream (deterministic);
    /// `prep` makes the mosaic of a reverse-ISP raw frame.
    pub fn from_rgb_via(
        img: &Image<[u8; 3]>,
        domain: Domain,
        cfa: Cfa,
        pipeline: &InputPipeline,
        index: u64,
        prep: &MosaicPrep,
    ) -> Result<Self, TrainError> {
        let (noise, seed) = match *pipeline {
            InputPipeline::Sampled => return Ok(Self::from_rgb(img, domain, cfa)),
            InputPipeline::ReverseIsp { noise, seed } => (noise, seed),
        };
        let (w, h) = (img.width() & !1, img.height() & !1);
        let even = if (w, h) == img.dimensions() {
            img.clone()
        } else {
            Image::from_fn(w, h, |x, y| img.get(x, y))
        };
        let profile = CameraProfile::default();
        let opts = ReverseIspOptions {
            cfa,
            noise: noise.map(|n| n.params()),
            seed: image_seed(seed, index),
            ..ReverseIspOptions::for_profile(&profile)
        };
        let raw = raw_from_srgb(even.view(), &profile, &opts)?;
        Ok(match domain {
            Domain::Mosaic => DomainImage::Mosaic(prep.mosaic(&raw)?),
            Domain::Colour => {
                DomainImage::Colour(srgb_from_raw(&raw, &profile, &ForwardIspOptions::default())?)
            }
            Domain::Grey => DomainImage::Grey(grey_from_rgb_u8(
                &srgb_from_raw(&raw, &profile, &ForwardIspOptions::default())?.view(),
            )),
        })
    }
    /// HOG input view.
    pub fn input(&self) -> HogInput<'_> {
        match self {
            DomainImage::Colour(c) => HogInput::Rgb8(c.view()),
            DomainImage::Grey(g) => HogInput::GreyU8(g.view()),
            DomainImage::Mosaic(m) => HogInput::Mosaic(m.view()),
        }
    }
    /// (width, height).
    pub fn dimensions(&self) -> (usize, usize) {
        self.input().dimensions()
    }
    /// Resized copy (mosaic: CFA-preserving; sizes rounded to even).
    pub fn resized(&self, w: usize, h: usize) -> Self {
        let mut d = Image::new(0, 0);
        match self {
            DomainImage::Colour(c) => {
                let planes: Vec<Image<f32>> = (0..3)
                    .map(|k| {
                        let mut o = Image::new(0, 0);
                        resize_bilinear(c.map(|p| p[k] as f32).view(), w, h, &mut o).expect("non-empty");
                        o
                    })
                    .collect();
                DomainImage::Colour(Image::from_fn(w, h, |x, y| {
                    [0, 1, 2].map(|k| planes[k].get(x, y).round().clamp(0.0, 255.0) as u8)
                }))
            }
            DomainImage::Grey(g) => {
                resize_bilinear(g.map(|p| p as f32).view(), w, h, &mut d).expect("non-empty");
                DomainImage::Grey(d.map(|v| v.round().clamp(0.0, 255.0) as u8))
            }
            DomainImage::Mosaic(m) => {
                resize_mosaic(m.view(), w & !1, h & !1, &mut d).expect("even, non-empty");
                DomainImage::Mosaic(d)
            }
        }
    }
}

/// A raw scene of the shared data rendered to sRGB by the forward ISP with its sensor's profile.
pub fn raw_scene_srgb(scene: &RawInput) -> Result<Image<[u8; 3]>, TrainError> {
    let data_err = |what: String| TrainError::Data {
        path: scene.rel.into(),
        what,
    };
    let frame = load_raw_frame(scene).map_err(|e| data_err(e.to_string()))?;
    Ok(srgb_from_raw(
        &frame,
        &raw_profile(scene),
        &ForwardIspOptions::default(),
    )?)
}

/// Load an RGB image.
pub fn load_rgb(path: &Path) -> Result<Image<[u8; 3]>, TrainError> {
    crate::image_io::load_rgb8(path).map_err(|e| TrainError::Data {
        path: e.path,
        what: e.source.to_string(),
    })
}

/// Descriptor of the 64x128 window of a 96x160 INRIA crop.
pub fn positive_descriptor(spec: &HogSpec, img: &DomainImage) -> Result<Vec<f32>, TrainError> {
    let mut g = BlockGrid::empty();
    block_grid(spec, &img.input(), Exec::Parallel, &mut g)?;
    Ok(g.window_descriptor(spec, POS_WINDOW_CELL, POS_WINDOW_CELL)?)
}

/// `n` random windows at random scales of a negative image.
pub fn random_negatives(
    spec: &HogSpec,
    img: &DomainImage,
    n: usize,
    rng: &mut impl Rng,
) -> Result<Vec<Vec<f32>>, TrainError> {
    let (w, h) = img.dimensions();
    let max_s = (w as f64 / spec.win_width() as f64).min(h as f64 / spec.win_height() as f64);
    let mut out = Vec::new();
    if max_s < 1.0 {
        return Ok(out);
    }
    let mut g = BlockGrid::empty();
    // Two scales per image, half the windows each.
    for part in [n / 2, n - n / 2] {
        let s = rng.random_range(1.0..=max_s);
        let (lw, lh) = (
            ((w as f64 / s).round() as usize).max(spec.win_width()),
            ((h as f64 / s).round() as usize).max(spec.win_height()),
        );
        let lvl = if (lw, lh) == (w, h) {
            img.clone()
        } else {
            img.resized(lw, lh)
        };
        block_grid(spec, &lvl.input(), Exec::Parallel, &mut g)?;
        let (nwx, nwy) = g.windows(spec);
        if nwx == 0 || nwy == 0 {
            continue;
        }
        for _ in 0..part {
            let (wx, wy) = (rng.random_range(0..nwx), rng.random_range(0..nwy));
            out.push(g.window_descriptor(spec, wx, wy)?);
        }
    }
    Ok(out)
}
