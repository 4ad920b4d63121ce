//! Linear SVM detector models: our file format, validation, and import of OpenCV weight vectors.
//!
//! # File format (`.json`, format `mosaicd-hog-svm`, version 1)
//!
//! One JSON object:
//!
//! ```json
//! { "format": "mosaicd-hog-svm", "version": 1,
//!   "win_width": 64, "win_height": 128, "cell_size": 8, "block_size": 16, "block_stride": 8,
//!   "nbins": 9, "gamma_correction": true, "l2hys_threshold": 0.2,
//!   "domain": "mosaic",            // mosaic | grey | colour: the input the weights were trained on
//!   "mosaic_taps": "same-site",    // mosaic input's derivative: same-site ((I(x+2) − I(x−2))/2)
//!                                  // or paper (I(x+1) − I(x−1)); absent = same-site
//!   "mosaic_tone": "srgb",         // how raw values become the mosaic: linear (black-subtracted,
//!                                  // scaled) or srgb (white balance + sRGB curve per site);
//!                                  // absent = linear (raw::MosaicTone)
//!   "provenance": { ... },         // free-form: command, seed, data, date, metrics
//!   "bias": -0.5, "weights": [ ... 3780 values in OpenCV descriptor order ... ] }
//! ```
//!
//! The score of a window is `weights · descriptor + bias`; a window "fires" when the score is at
//! least the detector's hit threshold. OpenCV stores the bias as element 3780 of the same vector
//! (`getDefaultPeopleDetector()`); [`LinearModel::from_opencv_vector`] splits it off.
//!
//! ```
//! use mosaicd::detect::model::{Domain, LinearModel};
//! let m = LinearModel::from_opencv_vector(&vec![0.0; 3781], Domain::Grey, "zeros").unwrap();
//! assert_eq!(m.weights.len(), 3780);
//! assert!(LinearModel::from_opencv_vector(&[0.0; 10], Domain::Grey, "short").is_err());
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::features::hog::{
    HogOptions, HogSpec, MosaicTaps, MosaicTone, BLOCK_SIZE, BLOCK_STRIDE, CELL_SIZE,
};
use crate::npy::NpyArray;

/// Format tag written in every model file.
pub const FORMAT: &str = "mosaicd-hog-svm";
/// Current format version.
pub const VERSION: u32 = 1;
/// Largest detection window side a model file may declare, pixels (OpenCV's people detector is
/// 64x128). With at most 255 bins this bounds a model to about 4 million weights.
pub const MAX_WINDOW_SIDE: usize = 512;
/// Largest model file [`LinearModel::load`] reads, bytes (checked with `stat` before reading).
pub const MAX_MODEL_FILE_BYTES: u64 = 128 << 20;

/// Errors loading or validating a model.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// File unreadable.
    #[error("cannot read model {path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Not parseable.
    #[error("model {origin} is not valid: {what}")]
    Parse {
        /// File or description.
        origin: String,
        /// What is wrong.
        what: String,
    },
    /// Weight vector length does not match the geometry.
    #[error("model {origin} has {actual} weights but its geometry (window {win_width}x{win_height}, {nbins} bins) needs {expected} (+1 optional bias for OpenCV vectors)")]
    WrongLength {
        /// File or description.
        origin: String,
        /// Weights present.
        actual: usize,
        /// Weights needed.
        expected: usize,
        /// Window width.
        win_width: usize,
        /// Window height.
        win_height: usize,
        /// Bins.
        nbins: usize,
    },
    /// Geometry this implementation does not compute.
    #[error("model {origin}: {what} is {actual}, only {supported} is supported")]
    Unsupported {
        /// File or description.
        origin: String,
        /// Field.
        what: &'static str,
        /// Value found.
        actual: String,
        /// Value supported.
        supported: String,
    },
    /// The model was trained on another input domain than the one it is applied to (only an
    /// error where the caller asks for strict matching).
    #[error("model {origin} is for {model:?} input, the frame is {input:?}")]
    DomainMismatch {
        /// File.
        origin: String,
        /// Model domain.
        model: Domain,
        /// Input domain.
        input: Domain,
    },
}

/// The input a model was trained on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Domain {
    /// Raw Bayer mosaic, mosaic gradients.
    Mosaic,
    /// Grey image.
    Grey,
    /// Colour image (OpenCV max-magnitude channel).
    Colour,
}

impl Domain {
    /// The name model files and `--as` use: `mosaic`, `grey` or `colour`.
    pub fn name(self) -> &'static str {
        match self {
            Domain::Mosaic => "mosaic",
            Domain::Grey => "grey",
            Domain::Colour => "colour",
        }
    }
}

impl std::str::FromStr for Domain {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "mosaic" | "raw" | "bayer" => Ok(Domain::Mosaic),
            "grey" | "gray" => Ok(Domain::Grey),
            "colour" | "color" | "rgb" => Ok(Domain::Colour),
            o => Err(format!("unknown domain '{o}' (mosaic, grey, colour)")),
        }
    }
}

fn same_site() -> MosaicTaps {
    MosaicTaps::SameSite
}

/// A linear SVM over HOG descriptors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearModel {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// Window width.
    pub win_width: usize,
    /// Window height.
    pub win_height: usize,
    /// Cell size (8).
    pub cell_size: usize,
    /// Block size (16).
    pub block_size: usize,
    /// Block stride (8).
    pub block_stride: usize,
    /// Orientation bins.
    pub nbins: usize,
    /// Square-root gamma.
    pub gamma_correction: bool,
    /// L2-Hys clip.
    pub l2hys_threshold: f32,
    /// Training input domain.
    pub domain: Domain,
    /// The derivative the model's features use on mosaic input (applies to any model run on a
    /// mosaic; `--mosaic-taps` and `compute.mosaic_taps` may override it). Files without the
    /// field predate it and were made with [`MosaicTaps::SameSite`].
    #[serde(default = "same_site")]
    pub mosaic_taps: MosaicTaps,
    /// How a raw frame's values become the mosaic this model reads
    /// ([`crate::raw::MosaicTone`]; `compute.mosaic_tone` and `--mosaic-tone` may override
    /// it). Files without the field predate it and were made with [`MosaicTone::Linear`];
    /// OpenCV's imported weights get [`MosaicTone::Linear`] too (on clean frames they do better
    /// with `srgb`, under noise worse: docs/detection.md, "The mosaic's tone").
    #[serde(default)]
    pub mosaic_tone: MosaicTone,
    /// Where the weights came from (command, seed, data, metrics).
    #[serde(default)]
    pub provenance: serde_json::Value,
    /// Bias b in `w·x + b`.
    pub bias: f32,
    /// Weights in OpenCV descriptor order.
    pub weights: Vec<f32>,
}

impl LinearModel {
    /// A model with OpenCV's default geometry from a weight vector of 3780 (+ optional bias).
    pub fn from_opencv_vector(v: &[f32], domain: Domain, origin: &str) -> Result<Self, ModelError> {
        let o = HogOptions::default();
        let spec = HogSpec::new(&o).expect("default options are valid");
        let n = spec.descriptor_len();
        let (weights, bias) = if v.len() == n {
            (v.to_vec(), 0.0)
        } else if v.len() == n + 1 {
            (v[..n].to_vec(), v[n])
        } else {
            return Err(ModelError::WrongLength {
                origin: origin.to_string(),
                actual: v.len(),
                expected: n,
                win_width: o.win_width,
                win_height: o.win_height,
                nbins: o.nbins,
            });
        };
        Ok(Self {
            format: FORMAT.into(),
            version: VERSION,
            win_width: o.win_width,
            win_height: o.win_height,
            cell_size: CELL_SIZE,
            block_size: BLOCK_SIZE,
            block_stride: BLOCK_STRIDE,
            nbins: o.nbins,
            gamma_correction: o.gamma_correction,
            l2hys_threshold: o.l2hys_threshold,
            domain,
            mosaic_taps: o.mosaic_taps,
            mosaic_tone: MosaicTone::Linear,
            provenance: serde_json::json!({ "imported_from": origin }),
            bias,
            weights,
        })
    }

    /// The HOG spec this model needs, after validating geometry and length.
    pub fn hog_spec(&self, origin: &str) -> Result<HogSpec, ModelError> {
        let unsupported = |what, actual: usize, supported: usize| ModelError::Unsupported {
            origin: origin.to_string(),
            what,
            actual: actual.to_string(),
            supported: supported.to_string(),
        };
        if self.format != FORMAT {
            return Err(ModelError::Parse {
                origin: origin.into(),
                what: format!("format is '{}', expected '{FORMAT}'", self.format),
            });
        }
        if self.version != VERSION {
            return Err(unsupported("version", self.version as usize, VERSION as usize));
        }
        if self.cell_size != CELL_SIZE {
            return Err(unsupported("cell_size", self.cell_size, CELL_SIZE));
        }
        if self.block_size != BLOCK_SIZE {
            return Err(unsupported("block_size", self.block_size, BLOCK_SIZE));
        }
        if self.block_stride != BLOCK_STRIDE {
            return Err(unsupported("block_stride", self.block_stride, BLOCK_STRIDE));
        }
        // The geometry comes from the file: bound it before anything multiplies it (a window of
        // 32x6148914691236517216 made the descriptor length wrap to 8 and the scorer index out of
        // bounds).
        let window = |what, actual: usize| ModelError::Unsupported {
            origin: origin.to_string(),
            what,
            actual: actual.to_string(),
            supported: format!("{BLOCK_SIZE}..={MAX_WINDOW_SIDE} (a multiple of {CELL_SIZE})"),
        };
        for (what, side) in [("win_width", self.win_width), ("win_height", self.win_height)] {
            if !(BLOCK_SIZE..=MAX_WINDOW_SIDE).contains(&side) || side % CELL_SIZE != 0 {
                return Err(window(what, side));
            }
        }
        if !(2..=255).contains(&self.nbins) {
            return Err(ModelError::Unsupported {
                origin: origin.to_string(),
                what: "nbins",
                actual: self.nbins.to_string(),
                supported: "2..=255".into(),
            });
        }
        let opts = HogOptions {
            win_width: self.win_width,
            win_height: self.win_height,
            nbins: self.nbins,
            win_sigma: None,
            l2hys_threshold: self.l2hys_threshold,
            gamma_correction: self.gamma_correction,
            mosaic_taps: self.mosaic_taps,
        };
        let spec = HogSpec::new(&opts).map_err(|e| ModelError::Parse {
            origin: origin.into(),
            what: e.to_string(),
        })?;
        if self.weights.len() != spec.descriptor_len() {
            return Err(ModelError::WrongLength {
                origin: origin.into(),
                actual: self.weights.len(),
                expected: spec.descriptor_len(),
                win_width: self.win_width,
                win_height: self.win_height,
                nbins: self.nbins,
            });
        }
        if !self.bias.is_finite() || self.weights.iter().any(|w| !w.is_finite()) {
            return Err(ModelError::Parse {
                origin: origin.into(),
                what: "weights or bias not finite".into(),
            });
        }
        Ok(spec)
    }

    /// Parse our JSON format and validate it.
    pub fn from_json(text: &str, origin: &str) -> Result<Self, ModelError> {
        let m: LinearModel = serde_json::from_str(text).map_err(|e| ModelError::Parse {
            origin: origin.into(),
            what: e.to_string(),
        })?;
        m.hog_spec(origin)?;
        Ok(m)
    }

    /// Serialise to our JSON format.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("model serialises")
    }

    /// Write to a file.
    pub fn save(&self, path: &Path) -> Result<(), ModelError> {
        std::fs::write(path, self.to_json()).map_err(|source| ModelError::Io {
            path: path.into(),
            source,
        })
    }

    /// Load any supported file: `.json` (ours), `.npy` (OpenCV vector), `.yml`/`.yaml` (OpenCV
    /// `HOGDescriptor` with `SVMDetector`), anything else as whitespace/comma-separated text.
    /// OpenCV vectors get `domain` (they do not record one).
    pub fn load(path: &Path, domain_for_opencv: Domain) -> Result<Self, ModelError> {
        let origin = path.display().to_string();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if ext == "npy" {
            let a = NpyArray::read(path).map_err(|e| ModelError::Parse {
                origin: origin.clone(),
                what: e.to_string(),
            })?;
            let v: Vec<f32> = a.data.iter().map(|&x| x as f32).collect();
            return Self::from_opencv_vector(&v, domain_for_opencv, &origin);
        }
        let text = read_text_at_most(path, MAX_MODEL_FILE_BYTES)?;
        match ext.as_str() {
            "json" => Self::from_json(&text, &origin),
            "yml" | "yaml" => Self::from_opencv_yaml(&text, domain_for_opencv, &origin),
            _ => {
                let v = parse_numbers(&text, &origin)?;
                Self::from_opencv_vector(&v, domain_for_opencv, &origin)
            }
        }
    }

    /// Parse an OpenCV `HOGDescriptor` YAML (`hog.save("x.yml")`): geometry keys are checked
    /// against ours, `SVMDetector` holds the weights (+ bias).
    pub fn from_opencv_yaml(text: &str, domain: Domain, origin: &str) -> Result<Self, ModelError> {
        let pair = |key: &str| -> Option<(usize, usize)> {
            let v = yaml_value(text, key)?;
            let n: Vec<usize> = v
                .trim()
                .trim_matches(|c| c == '[' || c == ']')
                .split(',')
                .filter_map(|s| s.trim().parse().ok())
                .collect();
            (n.len() == 2).then(|| (n[0], n[1]))
        };
        let want = [
            ("winSize", (64usize, 128usize)),
            ("blockSize", (BLOCK_SIZE, BLOCK_SIZE)),
            ("blockStride", (BLOCK_STRIDE, BLOCK_STRIDE)),
            ("cellSize", (CELL_SIZE, CELL_SIZE)),
        ];
        for (k, w) in want {
            if let Some(p) = pair(k) {
                if p != w {
                    return Err(ModelError::Unsupported {
                        origin: origin.into(),
                        what: "OpenCV geometry",
                        actual: format!("{k} {p:?}"),
                        supported: format!("{k} {w:?}"),
                    });
                }
            }
        }
        if let Some(nb) = yaml_value(text, "nbins").and_then(|v| v.trim().parse::<usize>().ok()) {
            if nb != 9 {
                return Err(ModelError::Unsupported {
                    origin: origin.into(),
                    what: "nbins",
                    actual: nb.to_string(),
                    supported: "9".into(),
                });
            }
        }
        let start = text.find("SVMDetector").ok_or_else(|| ModelError::Parse {
            origin: origin.into(),
            what: "no SVMDetector key".into(),
        })?;
        let rest = &text[start..];
        let open = rest.find('[').ok_or_else(|| ModelError::Parse {
            origin: origin.into(),
            what: "SVMDetector is not a [ ] sequence".into(),
        })?;
        // The closing bracket after the opening one (a `]` before it made the slice panic: found
        // by the model_files fuzz target).
        let body = &rest[open + 1..];
        let close = body.find(']').ok_or_else(|| ModelError::Parse {
            origin: origin.into(),
            what: "SVMDetector sequence not closed".into(),
        })?;
        let v = parse_numbers(&body[..close], origin)?;
        let mut m = Self::from_opencv_vector(&v, domain, origin)?;
        if let Some(g) = yaml_value(text, "gammaCorrection").and_then(|v| v.trim().parse::<i32>().ok()) {
            m.gamma_correction = g != 0;
        }
        if let Some(t) = yaml_value(text, "L2HysThreshold").and_then(|v| v.trim().parse::<f32>().ok()) {
            m.l2hys_threshold = t;
        }
        Ok(m)
    }
}

/// A text file of at most `max` bytes, `stat`ed before it is read.
pub(crate) fn read_text_at_most(path: &Path, max: u64) -> Result<String, ModelError> {
    use crate::bounded_read::{read_at_most, ReadAtMostError};
    let io = |source| ModelError::Io {
        path: path.into(),
        source,
    };
    let bytes = read_at_most(path, max).map_err(|e| match e {
        ReadAtMostError::Io(source) => io(source),
        ReadAtMostError::TooLarge { size } => ModelError::Parse {
            origin: path.display().to_string(),
            what: format!("file is {size} bytes, more than the {max} bytes a model file may have"),
        },
    })?;
    // As `read_to_string` reports text that is not UTF-8: an I/O error of kind InvalidData.
    String::from_utf8(bytes).map_err(|e| io(std::io::Error::new(std::io::ErrorKind::InvalidData, e)))
}

/// `key: value` on one line of a simple YAML document.
fn yaml_value<'a>(text: &'a str, key: &str) -> Option<&'a str> {
    text.lines().find_map(|l| {
        let t = l.trim_start();
        t.strip_prefix(key).and_then(|r| r.trim_start().strip_prefix(':'))
    })
}

fn parse_numbers(text: &str, origin: &str) -> Result<Vec<f32>, ModelError> {
    text.split(|c: char| c.is_whitespace() || c == ',')
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f32>().map_err(|_| ModelError::Parse {
                origin: origin.into(),
                what: format!("'{s}' is not a number"),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn domain_names_are_the_model_file_names() {
        for d in [Domain::Mosaic, Domain::Grey, Domain::Colour] {
            assert_eq!(serde_json::to_value(d).unwrap(), d.name());
            assert_eq!(d.name().parse::<Domain>().unwrap(), d);
        }
    }

    fn model() -> LinearModel {
        let v: Vec<f32> = (0..3781).map(|i| (i as f32 * 0.37).sin()).collect();
        LinearModel::from_opencv_vector(&v, Domain::Mosaic, "test").unwrap()
    }

    #[test]
    fn mosaic_taps_are_written_and_older_files_read_as_same_site() {
        let mut m = model();
        assert_eq!(m.mosaic_taps, MosaicTaps::SameSite);
        m.mosaic_taps = MosaicTaps::Paper;
        assert!(
            m.to_json().contains("\"mosaic_taps\":\"paper\""),
            "{}",
            m.to_json()
        );
        assert_eq!(LinearModel::from_json(&m.to_json(), "mem").unwrap(), m);
        let mut v: serde_json::Value = serde_json::from_str(&m.to_json()).unwrap();
        v.as_object_mut().unwrap().remove("mosaic_taps");
        let old = LinearModel::from_json(&v.to_string(), "old").unwrap();
        assert_eq!(old.mosaic_taps, MosaicTaps::SameSite);
        assert_eq!(
            old.hog_spec("old").unwrap().options().mosaic_taps,
            MosaicTaps::SameSite
        );
        v["mosaic_taps"] = serde_json::json!("sideways");
        let e = LinearModel::from_json(&v.to_string(), "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad") && e.contains("sideways"), "{e}");
    }

    #[test]
    fn mosaic_tone_is_written_and_older_files_and_opencv_weights_read_as_linear() {
        let mut m = model();
        assert_eq!(m.mosaic_tone, MosaicTone::Linear);
        m.mosaic_tone = MosaicTone::Srgb;
        assert!(
            m.to_json().contains("\"mosaic_tone\":\"srgb\""),
            "{}",
            m.to_json()
        );
        assert_eq!(LinearModel::from_json(&m.to_json(), "mem").unwrap(), m);
        m.mosaic_tone = MosaicTone::Linear;
        assert_eq!(LinearModel::from_json(&m.to_json(), "mem").unwrap(), m);
        let mut v: serde_json::Value = serde_json::from_str(&m.to_json()).unwrap();
        v.as_object_mut().unwrap().remove("mosaic_tone");
        assert_eq!(
            LinearModel::from_json(&v.to_string(), "old").unwrap().mosaic_tone,
            MosaicTone::Linear
        );
        v["mosaic_tone"] = serde_json::json!("log");
        let e = LinearModel::from_json(&v.to_string(), "bad")
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad") && e.contains("log"), "{e}");
    }

    #[test]
    fn json_round_trip() {
        let m = model();
        let back = LinearModel::from_json(&m.to_json(), "mem").unwrap();
        assert_eq!(m, back);
        assert_eq!(back.bias, (3780.0f32 * 0.37).sin());
    }

    #[test]
    fn wrong_length_names_both() {
        let mut m = model();
        m.weights.pop();
        let e = LinearModel::from_json(&m.to_json(), "mem").unwrap_err();
        let s = e.to_string();
        assert!(s.contains("3779") && s.contains("3780"), "{s}");
        m.weights.push(0.0);
        m.cell_size = 6;
        let e = LinearModel::from_json(&m.to_json(), "mem").unwrap_err();
        assert!(e.to_string().contains("cell_size is 6"), "{e}");
    }

    /// The crafted model of the hostile-input review: a 32x6148914691236517216 window with 2 bins
    /// made `descriptor_len` wrap to 8, so 8 weights passed the length check and `mosaicd detect`
    /// panicked in the scorer. Now the geometry is refused, naming the field.
    #[test]
    fn absurd_geometry_is_refused_not_wrapped() {
        let crafted = serde_json::json!({
            "format": FORMAT, "version": 1, "win_width": 32,
            "win_height": 6148914691236517216usize, "cell_size": 8, "block_size": 16,
            "block_stride": 8, "nbins": 2, "gamma_correction": true, "l2hys_threshold": 0.2,
            "domain": "mosaic", "bias": 0.0, "weights": [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        });
        let e = LinearModel::from_json(&crafted.to_string(), "crafted.json").unwrap_err();
        assert!(
            matches!(&e, ModelError::Unsupported { what: "win_height", actual, .. } if actual == "6148914691236517216"),
            "{e}"
        );
        let mut m = model();
        for (w, h, nbins, field) in [
            (64, 520, 9, "win_height"),
            (usize::MAX - 7, 128, 9, "win_width"),
            (64, 12, 9, "win_height"),
            (64, 128, 1 << 40, "nbins"),
            (64, 128, 1, "nbins"),
        ] {
            (m.win_width, m.win_height, m.nbins) = (w, h, nbins);
            match m.hog_spec("m") {
                Err(ModelError::Unsupported { what, .. }) => assert_eq!(what, field, "{w}x{h} {nbins}"),
                other => panic!("{w}x{h} {nbins}: {other:?}"),
            }
        }
        // The largest window allowed still validates with a matching weight vector.
        (m.win_width, m.win_height, m.nbins) = (MAX_WINDOW_SIDE, MAX_WINDOW_SIDE, 9);
        let blocks = (MAX_WINDOW_SIDE - BLOCK_SIZE) / BLOCK_STRIDE + 1;
        m.weights = vec![0.0; blocks * blocks * 4 * 9];
        assert_eq!(m.hog_spec("m").unwrap().descriptor_len(), m.weights.len());
    }

    #[test]
    fn oversized_model_files_are_refused_before_reading() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.json");
        let f = std::fs::File::create(&p).unwrap();
        f.set_len(MAX_MODEL_FILE_BYTES + 1).unwrap(); // sparse: no disk, no read
        let e = LinearModel::load(&p, Domain::Grey).unwrap_err();
        assert!(e.to_string().contains("more than"), "{e}");
    }

    #[test]
    fn text_and_yaml_import() {
        let v: Vec<String> = (0..3781).map(|i| format!("{}", i as f32 * 1e-3)).collect();
        let t = parse_numbers(&v.join("\n"), "t").unwrap();
        let m = LinearModel::from_opencv_vector(&t, Domain::Grey, "t").unwrap();
        assert_eq!(m.bias, 3780.0f32 * 1e-3);
        let yaml = format!(
            "%YAML:1.0\n---\nhog:\n   winSize: [ 64, 128 ]\n   blockSize: [ 16, 16 ]\n   nbins: 9\n   gammaCorrection: 1\n   SVMDetector: [ {} ]\n",
            v.join(",\n      ")
        );
        let y = LinearModel::from_opencv_yaml(&yaml, Domain::Grey, "y").unwrap();
        assert_eq!(y.weights, m.weights);
        let bad = yaml.replace("[ 64, 128 ]", "[ 48, 96 ]");
        assert!(LinearModel::from_opencv_yaml(&bad, Domain::Grey, "y").is_err());
        // A `]` before the sequence's `[` (the fuzzer's crash) is an error, not a slice panic.
        let e = LinearModel::from_opencv_yaml("SVMDetector: ] 1, 2 [ 3", Domain::Grey, "y").unwrap_err();
        assert!(e.to_string().contains("not closed"), "{e}");
    }
}
