//! Models compiled into the binary and addressed by name, so that the daemon's default detector
//! needs no file on the box and never reads the shared data directory.
//!
//! `compute.model` in a config and `--model` on the command line take, in this order:
//! - a built-in name from [`SHIPPED`] (`mosaic-raw-srgb`, …): the model file of the same stem
//!   under `models/` in the repository, compiled in with `include_str!` and parsed on use;
//! - [`crate::detect::OPENCV_DEFAULT`] (`opencv-default`): OpenCV's people detector, read from the
//!   shared data directory (`$MOSAICD_DATA`), where those weights are present;
//! - otherwise a model file path (`.json` ours; `.npy`, `.yml`, text = OpenCV vectors).
//!
//! The default, [`DEFAULT_MODEL`], is the raw-mosaic model with the best measured quality on data
//! it was not trained on (docs/detection.md, "Defaults"): `models/mosaic_raw_srgb.json`.

use std::path::Path;

use super::model::{Domain, LinearModel, ModelError};

/// One model compiled into the binary.
#[derive(Debug, Clone, Copy)]
pub struct ShippedModel {
    /// The name configs and the command line use (`mosaic-raw-srgb`).
    pub name: &'static str,
    /// The source file in the repository (`models/mosaic_raw_srgb.json`).
    pub file: &'static str,
    /// What it is for, in one line.
    pub summary: &'static str,
    json: &'static str,
}

macro_rules! shipped {
    ($name:literal, $file:literal, $summary:literal) => {
        ShippedModel {
            name: $name,
            file: concat!("models/", $file),
            summary: $summary,
            json: include_str!(concat!("../../models/", $file)),
        }
    };
}

/// Every built-in model.
pub const SHIPPED: &[ShippedModel] = &[
    shipped!(
        "mosaic-raw-srgb",
        "mosaic_raw_srgb.json",
        "raw mosaic, white-balanced sRGB tone, trained through the reverse ISP (the default)"
    ),
    shipped!(
        "mosaic-raw-srgb-low",
        "mosaic_raw_srgb_low.json",
        "raw mosaic, sRGB tone, trained at the paper's low noise (noisy, high-gain sensors)"
    ),
    shipped!(
        "mosaic-raw",
        "mosaic_raw.json",
        "raw mosaic, linear tone, trained through the reverse ISP"
    ),
    shipped!(
        "mosaic",
        "mosaic.json",
        "mosaic sampled from sRGB photographs (the paper's Bayer model)"
    ),
    shipped!(
        "colour",
        "colour.json",
        "colour images (the paper's colour model, for comparisons)"
    ),
    shipped!(
        "colour-raw",
        "colour_raw.json",
        "colour through the reverse and forward ISP (for comparisons)"
    ),
];

/// The daemon's and `mosaicd detect`'s default model.
pub const DEFAULT_MODEL: &str = "mosaic-raw-srgb";

/// The daemon's and `mosaicd detect`'s default feature-pyramid approximation: one exact level per
/// octave at scale step 1.05. Faster than the exact pyramid on every kernel path, and with the
/// default model USC AP 0.609 against 0.601 exact (paired bootstrap of the difference
/// [−0.011, +0.025]; docs/detection.md, "Defaults").
pub const DEFAULT_APPROX_LEVELS: usize = 14;

/// The built-in model called `name`, if there is one.
pub(crate) fn shipped(name: &str) -> Option<&'static ShippedModel> {
    SHIPPED.iter().find(|m| m.name == name)
}

impl ShippedModel {
    /// Parses the compiled-in model.
    pub fn load(&self) -> Result<LinearModel, ModelError> {
        LinearModel::from_json(self.json, &format!("built-in {} ({})", self.name, self.file))
    }
}

/// Why a named model could not be had.
#[derive(Debug, thiserror::Error)]
pub enum NamedModelError {
    /// The model (built-in or file) is not valid or not readable.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// `opencv-default` was asked for and the shared data directory does not hold its weights.
    #[error("model \"opencv-default\" reads OpenCV's weights from the shared data directory: {0} (or use a built-in model: {names})", names = builtin_names())]
    DataMissing(#[from] crate::data::DataMissing),
}

/// The built-in names, comma-separated, for messages and help.
pub(crate) fn builtin_names() -> String {
    SHIPPED.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
}

/// Loads the model `name` as configs and the command line name it (see the module docs).
/// OpenCV vectors get `domain_for_opencv` (they do not record one).
pub fn load_named(name: &str, domain_for_opencv: Domain) -> Result<LinearModel, NamedModelError> {
    if let Some(m) = shipped(name) {
        return Ok(m.load()?);
    }
    if name == super::OPENCV_DEFAULT {
        let p = crate::data::data_path(super::OPENCV_DEFAULT_MODEL)?;
        return Ok(LinearModel::load(&p, domain_for_opencv)?);
    }
    Ok(LinearModel::load(Path::new(name), domain_for_opencv)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_parses_and_equals_its_file() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        for m in SHIPPED {
            let built_in = m.load().unwrap_or_else(|e| panic!("{}: {e}", m.name));
            let file = LinearModel::load(&root.join(m.file), Domain::Mosaic).unwrap();
            assert_eq!(
                built_in.to_json(),
                file.to_json(),
                "{} differs from {}",
                m.name,
                m.file
            );
        }
    }

    #[test]
    fn the_default_is_built_in_and_needs_no_data_directory() {
        let m = shipped(DEFAULT_MODEL).expect("default is built in");
        assert_eq!(m.file, "models/mosaic_raw_srgb.json");
        // Resolved by name before any path or data lookup: works with no file and no data root.
        let a = load_named(DEFAULT_MODEL, Domain::Mosaic).unwrap();
        assert_eq!(a.to_json(), m.load().unwrap().to_json());
    }

    #[test]
    fn names_are_unique_and_unknown_names_are_paths() {
        let mut names: Vec<_> = SHIPPED.iter().map(|m| m.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), SHIPPED.len());
        let e = load_named("no-such-model", Domain::Mosaic).unwrap_err();
        assert!(e.to_string().contains("no-such-model"), "{e}");
    }
}
