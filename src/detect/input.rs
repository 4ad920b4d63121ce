//! The detector's input: a raw frame as the f32 mosaic in the model's tone.
//!
//! A mosaic model reads the frame in the tone it was trained in (`LinearModel::mosaic_tone`, which
//! the config's `compute.mosaic_tone` or `--mosaic-tone` may override before the detector is
//! built), with white-balance gains from the caller ([`Gains`]). [`MosaicPrep`] is that pair,
//! resolved once ([`MosaicPrep::for_model`]); the mapping itself is [`MosaicTone`]:
//!
//! ```text
//! linear:  out = 255 · (v − black) / (white − black), clamped at 0
//! srgb:    out = 255 · srgb(min(l · gain[c], 1)),  l = clamp((v − black) / (white − black), 0, 1)
//! ```
//!
//! [`MosaicInput`] is the daemon's form: it writes into a reused buffer and keeps the tone tables
//! while frames' levels, bit depth and gains stay the same. Both give the same values for the same
//! frame (the tables hold the formula's values).

use std::sync::{Arc, Mutex};

use super::model::LinearModel;
use crate::features::hog::MosaicTaps;
use crate::image::Image;
use crate::raw::levels::Gains;
use crate::raw::tone::{mosaic_from_raw_into, mosaic_from_raw_with, MosaicTone, ToneTables};
use crate::raw::{RawError, RawFrame};

/// `model` with the derivative and tone the configuration or command line asks for, where it asks.
pub fn with_overrides(
    mut model: LinearModel,
    taps: Option<MosaicTaps>,
    tone: Option<MosaicTone>,
) -> LinearModel {
    if let Some(t) = taps {
        model.mosaic_taps = t;
    }
    if let Some(t) = tone {
        model.mosaic_tone = t;
    }
    model
}

/// How a raw frame becomes a mosaic input: the tone and, for [`MosaicTone::Srgb`], where the
/// white-balance gains come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MosaicPrep {
    /// The tone.
    pub tone: MosaicTone,
    /// The gains (the reverse ISP's frames carry the profile's gains: [`Gains::FromFile`] is the
    /// true white balance, [`Gains::GreyWorld`] an estimate from the image).
    pub gains: Gains,
}

impl Default for MosaicPrep {
    /// Linear (the raw frame as it is).
    fn default() -> Self {
        Self {
            tone: MosaicTone::Linear,
            gains: Gains::FromFile,
        }
    }
}

impl MosaicPrep {
    /// `tone` with the frame's own gains (how training prepares mosaics).
    pub fn with_tone(tone: MosaicTone) -> Self {
        Self {
            tone,
            ..Self::default()
        }
    }

    /// The tone of `model` (with any override already applied to it) and `gains`.
    pub fn for_model(model: &LinearModel, gains: Gains) -> Self {
        Self {
            tone: model.mosaic_tone,
            gains,
        }
    }

    /// The `[r, g, b]` gains this tone applies to `frame` ([`MosaicTone::gains_for`]).
    pub fn gains_for(&self, frame: &RawFrame) -> Result<[f32; 3], RawError> {
        self.tone.gains_for(frame, self.gains)
    }

    /// The mosaic of `raw` in this tone (fixed gains are checked whatever the tone).
    pub fn mosaic(&self, raw: &RawFrame) -> Result<Image<f32>, RawError> {
        mosaic_from_raw_with(raw, self.tone, self.gains)
    }
}

/// The daemon's mosaic input: [`MosaicPrep`] into a reused buffer, with the last tone tables kept.
#[derive(Debug)]
pub struct MosaicInput {
    prep: MosaicPrep,
    /// The last tone tables, kept while frames' levels and gains stay the same.
    tables: Mutex<Option<Arc<ToneTables>>>,
}

impl MosaicInput {
    /// For `prep`, no tables yet.
    pub fn new(prep: MosaicPrep) -> Self {
        Self {
            prep,
            tables: Mutex::new(None),
        }
    }

    /// The tone and gains.
    pub fn prep(&self) -> MosaicPrep {
        self.prep
    }

    /// Write `frame`'s mosaic into `dst` (resized to `width · height`), parallel over strips of
    /// `strip_rows` rows. [`MosaicTone::Linear`] reads no gains (so needs none); the other tones
    /// resolve theirs for this frame (an error for [`Gains::FromFile`] on a frame without any).
    pub fn mosaic_into(
        &self,
        frame: &RawFrame,
        strip_rows: usize,
        dst: &mut Vec<f32>,
    ) -> Result<(), RawError> {
        match self.prep.tone {
            MosaicTone::Linear => mosaic_from_raw_into(frame, strip_rows, dst),
            tone => {
                let gains = tone.gains_for(frame, self.prep.gains)?;
                self.tables_for(frame, tone, gains)
                    .apply_into(frame, strip_rows, dst);
            }
        }
        Ok(())
    }

    /// The tables kept from the last frame, if any.
    pub fn kept_tables(&self) -> Option<Arc<ToneTables>> {
        self.slot().clone()
    }

    fn slot(&self) -> std::sync::MutexGuard<'_, Option<Arc<ToneTables>>> {
        // A poisoned lock only means another frame panicked while holding it; the slot is always
        // a complete value.
        self.tables.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The tone tables for `frame`, `tone` and `gains`: the kept ones when they were built for
    /// the same levels, bit depth and gains, else new ones (which are kept instead).
    fn tables_for(&self, frame: &RawFrame, tone: MosaicTone, gains: [f32; 3]) -> Arc<ToneTables> {
        // The lock is held only to look and to store, never while building, so frames in flight
        // with other gains (grey world) build theirs side by side.
        if let Some(t) = self.slot().as_ref().filter(|t| t.built_for(frame, tone, gains)) {
            return Arc::clone(t);
        }
        let t = Arc::new(ToneTables::new(frame, tone, gains));
        *self.slot() = Some(Arc::clone(&t));
        t
    }
}
