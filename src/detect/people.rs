//! One people detector for every caller: the daemon's stage, `mosaicd detect`, `eval detection`
//! and `bench detect` run either the HOG + linear SVM detector ([`Detector`]) or the ACF detector
//! ([`AcfDetector`]) through [`PeopleDetector`], so a model scores the same boxes wherever it runs.
//!
//! A model is named as `compute.model` and `--model` name HOG models ([`super::load_named`]: a
//! built-in name, `opencv-default` or a file), or is an ACF model file (`.json` whose `format` is
//! [`super::acf::FORMAT`], recognised by [`super::acf::is_acf_model_file`]). [`PeopleModel::load`]
//! reads either; [`PeopleModel::load_as`] insists on one kind (the daemon's `compute.detector`).
//!
//! Inputs ([`PeopleInput`]) are the three domains; a mosaic carries its CFA, which the ACF colour
//! channels read (the HOG detector does not need it: its mosaic gradients use same-colour taps
//! whatever the pattern).

use std::path::Path;
use std::time::Duration;

use super::acf::{is_acf_model_file, AcfDetector, AcfError, AcfModel, AcfOptions, AcfStats};
use super::detector::{DetectError, DetectStats, Detector, DetectorOptions};
use super::input::MosaicPrep;
use super::model::{Domain, LinearModel};
use super::shipped::{load_named, NamedModelError};
use crate::detect::channels::ChannelInput;
use crate::features::hog::{HogInput, MosaicTaps};
use crate::geometry::Detection;
use crate::image::ImageView;
use crate::raw::levels::Gains;
use crate::raw::tone::MosaicTone;
use crate::raw::Cfa;

/// The two detectors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DetectorKind {
    /// HOG + linear SVM (Dalal & Triggs).
    #[default]
    Hog,
    /// Aggregated channel features + boosted trees with a soft cascade (Dollár et al.).
    Acf,
}

impl DetectorKind {
    /// `"hog"` or `"acf"` (the config's and the command line's spelling).
    pub fn name(self) -> &'static str {
        match self {
            DetectorKind::Hog => "hog",
            DetectorKind::Acf => "acf",
        }
    }
}

impl std::fmt::Display for DetectorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for DetectorKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "hog" => Ok(DetectorKind::Hog),
            "acf" => Ok(DetectorKind::Acf),
            _ => Err(format!("{s:?}: expected \"hog\" or \"acf\"")),
        }
    }
}

/// Errors of loading or running a [`PeopleDetector`].
#[derive(Debug, thiserror::Error)]
pub enum PeopleError {
    /// A HOG model could not be had.
    #[error(transparent)]
    Named(#[from] NamedModelError),
    /// The HOG detector failed.
    #[error(transparent)]
    Hog(#[from] DetectError),
    /// An ACF model or the ACF detector failed.
    #[error(transparent)]
    Acf(#[from] AcfError),
    /// The model is of the other kind than the one asked for.
    #[error("{name} is {found} model, not {wanted} model")]
    WrongKind {
        /// The model as named.
        name: String,
        /// What was asked for.
        wanted: &'static str,
        /// What it is.
        found: &'static str,
    },
}

fn article(k: DetectorKind) -> &'static str {
    match k {
        DetectorKind::Hog => "a HOG",
        DetectorKind::Acf => "an ACF",
    }
}

/// A model of either detector.
#[derive(Debug, Clone, PartialEq)]
pub enum PeopleModel {
    /// HOG + linear SVM.
    Hog(LinearModel),
    /// ACF.
    Acf(AcfModel),
}

impl PeopleModel {
    /// The model `name`: an ACF model file, else a HOG model as [`load_named`] reads it (OpenCV
    /// vectors get `domain_for_opencv`).
    pub fn load(name: &str, domain_for_opencv: Domain) -> Result<Self, PeopleError> {
        if is_acf_model_file(Path::new(name)) {
            return Ok(PeopleModel::Acf(AcfModel::load(Path::new(name))?));
        }
        Ok(PeopleModel::Hog(load_named(name, domain_for_opencv)?))
    }

    /// [`PeopleModel::load`], refusing a model of the other kind ([`PeopleError::WrongKind`]): a
    /// HOG model (a built-in name, `opencv-default` or a HOG file) asked for as ACF, or an ACF
    /// file asked for as HOG.
    pub fn load_as(name: &str, kind: DetectorKind, domain_for_opencv: Domain) -> Result<Self, PeopleError> {
        let path = Path::new(name);
        let wrong = |found| PeopleError::WrongKind {
            name: name.into(),
            wanted: article(kind),
            found: article(found),
        };
        let acf_file = is_acf_model_file(path);
        match kind {
            DetectorKind::Hog if acf_file => Err(wrong(DetectorKind::Acf)),
            DetectorKind::Hog => Ok(PeopleModel::Hog(load_named(name, domain_for_opencv)?)),
            DetectorKind::Acf if acf_file => Ok(PeopleModel::Acf(AcfModel::load(path)?)),
            DetectorKind::Acf => {
                let hog_name = super::shipped::shipped(name).is_some() || name == super::OPENCV_DEFAULT;
                if hog_name || (path.is_file() && load_named(name, domain_for_opencv).is_ok()) {
                    return Err(wrong(DetectorKind::Hog));
                }
                // no file, or not a model of either kind: the ACF reader says why
                Ok(PeopleModel::Acf(AcfModel::load(path)?))
            }
        }
    }

    /// Which detector reads it.
    pub fn kind(&self) -> DetectorKind {
        match self {
            PeopleModel::Hog(_) => DetectorKind::Hog,
            PeopleModel::Acf(_) => DetectorKind::Acf,
        }
    }

    /// The domain it was trained on.
    pub fn domain(&self) -> Domain {
        match self {
            PeopleModel::Hog(m) => m.domain,
            PeopleModel::Acf(m) => m.domain,
        }
    }

    /// How raw frames become its mosaic.
    pub fn mosaic_tone(&self) -> MosaicTone {
        match self {
            PeopleModel::Hog(m) => m.mosaic_tone,
            PeopleModel::Acf(m) => m.mosaic_tone,
        }
    }

    /// The model with the derivative (HOG only: ACF's gradient is its own) and tone the
    /// configuration or command line asks for, where it asks.
    pub fn with_overrides(self, taps: Option<MosaicTaps>, tone: Option<MosaicTone>) -> Self {
        match self {
            PeopleModel::Hog(m) => PeopleModel::Hog(super::input::with_overrides(m, taps, tone)),
            PeopleModel::Acf(mut m) => {
                if let Some(t) = tone {
                    m.mosaic_tone = t;
                }
                PeopleModel::Acf(m)
            }
        }
    }

    /// The detector: HOG models with `hog`, ACF models with `acf`.
    pub fn build(self, hog: &DetectorOptions, acf: &AcfOptions) -> Result<PeopleDetector, PeopleError> {
        Ok(match self {
            PeopleModel::Hog(m) => PeopleDetector::Hog(Detector::new(m, hog)?),
            PeopleModel::Acf(m) => PeopleDetector::Acf(AcfDetector::new(m, acf)?),
        })
    }
}

/// A detector's input: a mosaic in 8-bit units with its pattern, grey or colour.
#[derive(Debug, Clone, Copy)]
pub enum PeopleInput<'a> {
    /// Mosaic (the model's tone already applied) and its CFA.
    Mosaic {
        /// The mosaic.
        image: ImageView<'a, f32>,
        /// Its pattern.
        cfa: Cfa,
    },
    /// Grey.
    Grey(ImageView<'a, u8>),
    /// Colour (RGB).
    Colour(ImageView<'a, [u8; 3]>),
}

impl<'a> PeopleInput<'a> {
    /// The HOG detector's view.
    pub fn hog(&self) -> HogInput<'a> {
        match *self {
            PeopleInput::Mosaic { image, .. } => HogInput::Mosaic(image),
            PeopleInput::Grey(g) => HogInput::GreyU8(g),
            PeopleInput::Colour(c) => HogInput::Rgb8(c),
        }
    }

    /// The ACF channels' view.
    pub fn channels(&self) -> ChannelInput<'a> {
        match *self {
            PeopleInput::Mosaic { image, cfa } => ChannelInput::Mosaic { image, cfa },
            PeopleInput::Grey(g) => ChannelInput::GreyU8(g),
            PeopleInput::Colour(c) => ChannelInput::Rgb8(c),
        }
    }
}

/// One call's statistics, as the detector that ran reports them.
#[derive(Debug, Clone, PartialEq)]
pub enum PeopleStats {
    /// HOG.
    Hog(DetectStats),
    /// ACF.
    Acf(AcfStats),
}

impl PeopleStats {
    /// Pyramid levels.
    pub fn levels(&self) -> usize {
        match self {
            PeopleStats::Hog(s) => s.levels,
            PeopleStats::Acf(s) => s.levels,
        }
    }

    /// Windows scored.
    pub fn windows(&self) -> usize {
        match self {
            PeopleStats::Hog(s) => s.windows,
            PeopleStats::Acf(s) => s.windows,
        }
    }

    /// Windows at or above the hit threshold, before suppression.
    pub fn hits(&self) -> usize {
        match self {
            PeopleStats::Hog(s) => s.hits,
            PeopleStats::Acf(s) => s.hits,
        }
    }

    /// Wall time of the call.
    pub fn total(&self) -> Duration {
        match self {
            PeopleStats::Hog(s) => s.total,
            PeopleStats::Acf(s) => s.total,
        }
    }
}

/// A HOG or ACF detector, built from a [`PeopleModel`].
#[derive(Debug, Clone)]
pub enum PeopleDetector {
    /// HOG + linear SVM.
    Hog(Detector),
    /// ACF.
    Acf(AcfDetector),
}

impl From<Detector> for PeopleDetector {
    fn from(d: Detector) -> Self {
        PeopleDetector::Hog(d)
    }
}

impl From<AcfDetector> for PeopleDetector {
    fn from(d: AcfDetector) -> Self {
        PeopleDetector::Acf(d)
    }
}

impl PeopleDetector {
    /// Which detector it is.
    pub fn kind(&self) -> DetectorKind {
        match self {
            PeopleDetector::Hog(_) => DetectorKind::Hog,
            PeopleDetector::Acf(_) => DetectorKind::Acf,
        }
    }

    /// The domain its model was trained on.
    pub fn domain(&self) -> Domain {
        match self {
            PeopleDetector::Hog(d) => d.model().domain,
            PeopleDetector::Acf(d) => d.model().domain,
        }
    }

    /// How raw frames become its mosaic.
    pub fn mosaic_tone(&self) -> MosaicTone {
        match self {
            PeopleDetector::Hog(d) => d.model().mosaic_tone,
            PeopleDetector::Acf(d) => d.model().mosaic_tone,
        }
    }

    /// The mosaic preparation of its model's tone with `gains`.
    pub fn mosaic_prep(&self, gains: Gains) -> MosaicPrep {
        MosaicPrep {
            tone: self.mosaic_tone(),
            gains,
        }
    }

    /// The detection window, pixels (the smallest person it finds at upsample 1 fits in it).
    pub fn window(&self) -> (usize, usize) {
        match self {
            PeopleDetector::Hog(d) => (d.hog_spec().win_width(), d.hog_spec().win_height()),
            PeopleDetector::Acf(d) => (d.model().win_width, d.model().win_height),
        }
    }

    /// Detections (after suppression, in the detector's order) and statistics. A frame smaller
    /// than the window even after the pyramid's upsampling is an error from either detector
    /// (the daemon's stage gives such frames no detections before calling).
    pub fn detect(&self, input: &PeopleInput) -> Result<(Vec<Detection>, PeopleStats), PeopleError> {
        match self {
            PeopleDetector::Hog(d) => {
                let (b, s) = d.detect(&input.hog())?;
                Ok((b, PeopleStats::Hog(s)))
            }
            PeopleDetector::Acf(d) => {
                let (b, s) = d.detect(&input.channels())?;
                Ok((b, PeopleStats::Acf(s)))
            }
        }
    }
}

/// For tests: the shipped raw-mosaic ACF model (`models/acf-mosaic.json`) scoring every window
/// with every tree (no soft cascade: neither its threshold nor its rejection trace), every window
/// a hit: boxes on any texture.
#[cfg(test)]
pub(crate) fn every_window_acf() -> PeopleDetector {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/acf-mosaic.json");
    let mut model = AcfModel::load(Path::new(path)).expect("the shipped ACF model");
    model.casc_thr = f32::NEG_INFINITY;
    model.casc_trace = None;
    let opts = AcfOptions {
        hit_threshold: -1e9,
        ..AcfOptions::default()
    };
    PeopleDetector::Acf(AcfDetector::new(model, &opts).expect("a valid model"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_parse_and_print() {
        for k in [DetectorKind::Hog, DetectorKind::Acf] {
            assert_eq!(k.name().parse::<DetectorKind>(), Ok(k));
            assert_eq!(k.to_string(), k.name());
        }
        assert!("HOG".parse::<DetectorKind>().is_err());
        assert!(""
            .parse::<DetectorKind>()
            .unwrap_err()
            .contains("\"hog\" or \"acf\""));
        assert_eq!(DetectorKind::default(), DetectorKind::Hog);
    }

    #[test]
    fn models_load_by_kind_and_the_other_kind_is_refused() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let hog_file = root.join("models/mosaic.json");
        let hog = hog_file.to_str().unwrap();
        let m = PeopleModel::load(hog, Domain::Mosaic).unwrap();
        assert_eq!(m.kind(), DetectorKind::Hog);
        let e = PeopleModel::load_as(hog, DetectorKind::Acf, Domain::Mosaic).unwrap_err();
        assert!(
            matches!(e, PeopleError::WrongKind { .. }) && e.to_string().contains("not an ACF model"),
            "{e}"
        );
        // a built-in HOG name is not an ACF model either; a missing file is a reading error
        let e =
            PeopleModel::load_as(super::super::DEFAULT_MODEL, DetectorKind::Acf, Domain::Mosaic).unwrap_err();
        assert!(matches!(e, PeopleError::WrongKind { .. }), "{e}");
        let e = PeopleModel::load_as("/no/such/acf.json", DetectorKind::Acf, Domain::Mosaic).unwrap_err();
        assert!(
            matches!(e, PeopleError::Acf(_)) && e.to_string().contains("/no/such/acf.json"),
            "{e}"
        );
        let dir = tempfile::tempdir().unwrap();
        let acf_file = dir.path().join("acf.json");
        let acf_model = tiny_acf_model();
        acf_model.save(&acf_file).unwrap();
        let acf = acf_file.to_str().unwrap();
        let m = PeopleModel::load_as(acf, DetectorKind::Acf, Domain::Mosaic).unwrap();
        assert_eq!(m, PeopleModel::Acf(acf_model));
        assert_eq!(PeopleModel::load(acf, Domain::Mosaic).unwrap(), m);
        let e = PeopleModel::load_as(acf, DetectorKind::Hog, Domain::Mosaic).unwrap_err();
        assert!(e.to_string().contains("is an ACF model, not a HOG model"), "{e}");
        // overrides: the tone reaches both kinds, the taps only HOG
        let m = m.with_overrides(Some(MosaicTaps::Paper), Some(MosaicTone::Srgb));
        assert_eq!(m.mosaic_tone(), MosaicTone::Srgb);
        let h = PeopleModel::load(hog, Domain::Mosaic)
            .unwrap()
            .with_overrides(Some(MosaicTaps::Paper), None);
        assert!(matches!(&h, PeopleModel::Hog(l) if l.mosaic_taps == MosaicTaps::Paper));
    }

    /// An ACF model with one stump on the magnitude channel.
    fn tiny_acf_model() -> AcfModel {
        use crate::detect::boost::{BoostOptions, BoostedTrees, Tree};
        use crate::detect::channels::{ChannelOptions, PyramidOptions, N_CHANNELS};
        AcfModel {
            format: super::super::acf::FORMAT.into(),
            version: super::super::acf::VERSION,
            domain: Domain::Mosaic,
            win_width: 64,
            win_height: 128,
            channels: ChannelOptions::default(),
            features: super::super::acf::FeatureSet::All,
            pyramid: PyramidOptions::default(),
            casc_thr: -1.0,
            casc_cal: 0.0,
            casc_trace: None,
            mosaic_tone: MosaicTone::Linear,
            boost: BoostOptions::default(),
            classifier: BoostedTrees {
                n_features: N_CHANNELS * 16 * 32,
                trees: vec![Tree {
                    fid: vec![(3 * 32 + 10) * 16 + 8, 0, 0],
                    thr: vec![0.05, 0.0, 0.0],
                    child: vec![1, 0, 0],
                    hs: vec![0.0, -0.5, 1.0],
                }],
            },
            provenance: serde_json::json!({"test": true}),
        }
    }

    #[test]
    fn both_detectors_run_through_one_call_and_refuse_frames_below_the_window() {
        use crate::image::Image;
        let img = Image::from_fn(160, 192, |x, y| ((x * 13 + y * 7 + x * y / 3) % 256) as f32);
        let input = PeopleInput::Mosaic {
            image: img.view(),
            cfa: Cfa::Rggb,
        };
        let acf = PeopleModel::Acf(tiny_acf_model())
            .build(&DetectorOptions::default(), &AcfOptions::default())
            .unwrap();
        assert_eq!((acf.kind(), acf.window()), (DetectorKind::Acf, (64, 128)));
        let (boxes, st) = acf.detect(&input).unwrap();
        let PeopleDetector::Acf(d) = &acf else {
            unreachable!()
        };
        let (want, _) = d.detect(&input.channels()).unwrap();
        assert_eq!(boxes, want);
        assert!(st.windows() > 0 && matches!(st, PeopleStats::Acf(_)));
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let hog = PeopleModel::load(root.join("models/mosaic.json").to_str().unwrap(), Domain::Mosaic)
            .unwrap()
            .build(
                &DetectorOptions {
                    hit_threshold: -1e6,
                    ..DetectorOptions::default()
                },
                &AcfOptions::default(),
            )
            .unwrap();
        assert_eq!(hog.window(), (64, 128));
        let (boxes, st) = hog.detect(&input).unwrap();
        let PeopleDetector::Hog(d) = &hog else {
            unreachable!()
        };
        assert_eq!(boxes, d.detect(&input.hog()).unwrap().0);
        assert!(!boxes.is_empty() && st.hits() > 0);
        // below the window: an error from either
        let small = Image::from_fn(62, 126, |x, _| x as f32);
        let input = PeopleInput::Mosaic {
            image: small.view(),
            cfa: Cfa::Rggb,
        };
        for det in [&acf, &hog] {
            let e = det.detect(&input).unwrap_err().to_string();
            assert!(e.contains("62") && e.contains("126"), "{:?}: {e}", det.kind());
        }
        // ... unless the pyramid starts magnified: then it is scanned like any frame
        let up = |m: PeopleModel| {
            m.build(
                &DetectorOptions {
                    upsample: 2.0,
                    hit_threshold: -1e6,
                    ..DetectorOptions::default()
                },
                &AcfOptions {
                    upsample: 2.0,
                    ..AcfOptions::default()
                },
            )
            .unwrap()
        };
        let hog_file = root.join("models/mosaic.json");
        for det in [
            up(PeopleModel::Acf(tiny_acf_model())),
            up(PeopleModel::load(hog_file.to_str().unwrap(), Domain::Mosaic).unwrap()),
        ] {
            let (_, st) = det.detect(&input).unwrap();
            assert!(st.windows() > 0, "{:?}", det.kind());
        }
    }
}
