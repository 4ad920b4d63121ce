//! The ACF people detector: aggregated channel features ([`crate::detect::channels`]) over the
//! fast pyramid, scored by boosted depth-2 trees with a soft cascade ([`super::boost`]), windows
//! every 4 pixels, non-maximum suppression.
//!
//! # Model file (`.json`, format `mosaicd-acf`, version 1)
//!
//! ```text
//! { "format": "mosaicd-acf", "version": 1,
//!   "domain": "mosaic",              // mosaic | grey | colour: the input it was trained on
//!   "win_width": 64, "win_height": 128,   // pixels; features: 10 x 16 x 32 blocks
//!   "channels": { ChannelOptions }, "pyramid": { PyramidOptions },
//!   "features": "gradient",               // optional (absent: "all"): the channels the trees may
//!                                         // read ([`FeatureSet`]; a channel ablation)
//!   "casc_thr": -1.0, "casc_cal": 0.005,  // soft cascade (casc_cal already added to the leaves)
//!   "casc_trace": [r_1, …, r_T],          // optional: calibrated per-tree rejection (replaces
//!                                         // casc_thr while scoring; boost::calibrate_trace)
//!   "mosaic_tone": "linear" | "srgb",     // how raw frames become the mosaic
//!   "boost": { BoostOptions of the last stage },
//!   "classifier": { "n_features": 5120, "trees": [ { "fid", "thr", "child", "hs" }, … ] },
//!   "provenance": { … free-form: trainer, seed, data, stages, times … } }
//! ```
//!
//! Feature `f = (c·H + y)·W + x` of a window is channel `c` at block `(x, y)` of the window
//! (`W x H` blocks). A window at block `(bx, by)` of a level with real scales `(sx, sy)` is the box
//! `(4·bx/sx, 4·by/sy, 64/sx, 128/sy)` in the frame: the whole 64x128 window, as the HOG detector
//! reports (Dollár reports the 41x100 box inside his 64x128 window).
//!
//! # Where we differ from Dollár's `acfDetect`
//! No channel padding, so windows stay inside the frame; boxes are the full window; the NMS is
//! ours ([`NmsMethod`]; Dollár's is greedy with overlap 0.65 over the smaller box).

mod kernels;

use std::path::Path;
use std::time::{Duration, Instant};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::boost::{BoostError, BoostOptions, BoostedTrees, Tree};
use super::detector::NmsMethod;
use super::model::{Domain, ModelError, MAX_MODEL_FILE_BYTES};
use super::nms::{greedy_nms, group_rectangles};
use crate::detect::channels::{
    pyramid, ChannelInput, ChannelOptions, ChannelPyramid, ChannelSpec, Channels, ChannelsError,
    PyramidOptions, MAG_CHANNEL, N_CHANNELS, SHRINK,
};
use crate::geometry::Detection;
use crate::raw::tone::MosaicTone;
use kernels::{goes_right, score_run, PackedTrees, Tree2};

/// The format name in ACF model files.
pub(crate) const FORMAT: &str = "mosaicd-acf";
/// Current format version.
pub(crate) const VERSION: u32 = 1;
/// Dollár's soft-cascade threshold.
pub const CASC_THR: f32 = -1.0;
/// Dollár's cascade calibration (added to every leaf after training).
pub(crate) const CASC_CAL: f32 = 0.005;
/// The score of a window the soft cascade rejects (the lowest finite `f32`): no detection at
/// any threshold.
pub(crate) const REJECTED: f32 = f32::MIN;

/// Errors of the ACF detector.
#[derive(Debug, Error)]
pub enum AcfError {
    /// Channel computation.
    #[error(transparent)]
    Channels(#[from] ChannelsError),
    /// The classifier.
    #[error(transparent)]
    Boost(#[from] BoostError),
    /// Reading or parsing a model file.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A model whose window and classifier disagree, or an option out of range.
    #[error("ACF model {origin}: {what}")]
    Invalid {
        /// File or description.
        origin: String,
        /// What is wrong.
        what: String,
    },
}

/// The channels a model's trees may read. Every channel is still computed (the pyramid is the
/// same); a model that reads fewer only never splits on the others, which [`AcfModel::validate`]
/// checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FeatureSet {
    /// All ten channels (Dollár's).
    #[default]
    All,
    /// The gradient magnitude and the six orientation channels: no colour (L, U, V) feature.
    Gradient,
}

impl FeatureSet {
    /// Both, for loops and option parsing.
    pub const ALL: [FeatureSet; 2] = [FeatureSet::All, FeatureSet::Gradient];

    /// The name in model files and on the command line: `all` or `gradient`.
    pub fn name(self) -> &'static str {
        match self {
            FeatureSet::All => "all",
            FeatureSet::Gradient => "gradient",
        }
    }

    /// The first channel the trees may read (the readable channels are this one and the ones
    /// after it).
    pub fn first_channel(self) -> usize {
        match self {
            FeatureSet::All => 0,
            FeatureSet::Gradient => MAG_CHANNEL,
        }
    }

    /// Whether this is the default, [`FeatureSet::All`] (not written into model files, so files
    /// from before the option are written back byte for byte).
    pub fn is_all(&self) -> bool {
        *self == FeatureSet::All
    }
}

/// A trained ACF detector.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AcfModel {
    /// Always `"mosaicd-acf"`.
    pub format: String,
    /// Always 1.
    pub version: u32,
    /// The input domain the model was trained on.
    pub domain: Domain,
    /// Window width, pixels (a multiple of 4).
    pub win_width: usize,
    /// Window height, pixels (a multiple of 4).
    pub win_height: usize,
    /// Channel options.
    pub channels: ChannelOptions,
    /// The channels the trees may read (absent in files from before the option: all).
    #[serde(default, skip_serializing_if = "FeatureSet::is_all")]
    pub features: FeatureSet,
    /// Pyramid options (per octave, approximated levels, λ; `upsample` is the default).
    pub pyramid: PyramidOptions,
    /// Soft-cascade threshold.
    pub casc_thr: f32,
    /// Calibration already added to every node value.
    pub casc_cal: f32,
    /// Calibrated per-tree rejection trace (`boost::calibrate_trace`): a window is
    /// rejected after tree `k` when its running score is `≤ casc_trace[k]`; when present it
    /// replaces `casc_thr` while scoring. Absent in models written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub casc_trace: Option<Vec<f32>>,
    /// How raw frames become the mosaic.
    #[serde(default)]
    pub mosaic_tone: MosaicTone,
    /// Boosting options of the final stage.
    pub boost: BoostOptions,
    /// The trees.
    pub classifier: BoostedTrees,
    /// Where the model came from.
    #[serde(default)]
    pub provenance: serde_json::Value,
}

impl AcfModel {
    /// Window size in blocks.
    pub fn window_blocks(&self) -> (usize, usize) {
        (self.win_width / SHRINK, self.win_height / SHRINK)
    }

    /// Features per window.
    pub fn n_features(&self) -> usize {
        let (w, h) = self.window_blocks();
        N_CHANNELS * w * h
    }

    /// Check the format, the geometry and the trees.
    pub fn validate(&self, origin: &str) -> Result<(), AcfError> {
        let bad = |what: String| {
            Err(AcfError::Invalid {
                origin: origin.into(),
                what,
            })
        };
        if self.format != FORMAT || self.version != VERSION {
            return bad(format!(
                "format {} version {}, expected {FORMAT} version {VERSION}",
                self.format, self.version
            ));
        }
        for (what, side) in [("win_width", self.win_width), ("win_height", self.win_height)] {
            if !(2 * SHRINK..=1024).contains(&side) || side % SHRINK != 0 {
                return bad(format!("{what} = {side}: a multiple of {SHRINK} in 8..=1024"));
            }
        }
        if self.classifier.n_features != self.n_features() {
            return bad(format!(
                "the classifier reads {} features, the {}x{} window has {}",
                self.classifier.n_features,
                self.win_width,
                self.win_height,
                self.n_features()
            ));
        }
        if !self.casc_thr.is_finite() && self.casc_thr != f32::NEG_INFINITY {
            return bad(format!("casc_thr = {}", self.casc_thr));
        }
        if let Some(t) = &self.casc_trace {
            if t.len() != self.classifier.trees.len() {
                return bad(format!(
                    "casc_trace has {} entries for {} trees",
                    t.len(),
                    self.classifier.trees.len()
                ));
            }
            if let Some(k) = t.iter().position(|r| r.is_nan() || *r == f32::INFINITY) {
                return bad(format!("casc_trace[{k}] = {}", t[k]));
            }
        }
        ChannelSpec::new(self.channels)?;
        self.classifier.validate()?;
        let (w, h) = self.window_blocks();
        let first = (self.features.first_channel() * w * h) as u32;
        for (i, t) in self.classifier.trees.iter().enumerate() {
            if let Some(k) = (0..t.fid.len()).find(|&k| t.child[k] != 0 && t.fid[k] < first) {
                return bad(format!(
                    "features \"{}\": tree {i} node {k} reads feature {} of channel {}",
                    self.features.name(),
                    t.fid[k],
                    t.fid[k] as usize / (w * h)
                ));
            }
        }
        Ok(())
    }

    /// Parse and validate our JSON.
    pub fn from_json(text: &str, origin: &str) -> Result<Self, AcfError> {
        let m: AcfModel = serde_json::from_str(text).map_err(|e| ModelError::Parse {
            origin: origin.into(),
            what: e.to_string(),
        })?;
        m.validate(origin)?;
        Ok(m)
    }

    /// Serialise.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("model serialises")
    }

    /// Write to `path`.
    pub fn save(&self, path: &Path) -> Result<(), AcfError> {
        std::fs::write(path, self.to_json()).map_err(|source| ModelError::Io {
            path: path.into(),
            source,
        })?;
        Ok(())
    }

    /// Read and validate `path`.
    pub fn load(path: &Path) -> Result<Self, AcfError> {
        let text = super::model::read_text_at_most(path, MAX_MODEL_FILE_BYTES)?;
        Self::from_json(&text, &path.display().to_string())
    }
}

/// Whether `path` is an ACF model file (a `.json` whose `format` is [`FORMAT`]); unreadable or
/// other files are not.
pub(crate) fn is_acf_model_file(path: &Path) -> bool {
    if path.extension().and_then(|e| e.to_str()) != Some("json") {
        return false;
    }
    #[derive(Deserialize)]
    struct Head {
        format: String,
    }
    super::model::read_text_at_most(path, MAX_MODEL_FILE_BYTES)
        .ok()
        .and_then(|t| serde_json::from_str::<Head>(&t).ok())
        .is_some_and(|h| h.format == FORMAT)
}

/// Detection options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AcfOptions {
    /// Scale of the first pyramid level (2 finds people half the window's height).
    pub upsample: f64,
    /// Approximated levels between exact ones (`None`: the model's).
    pub approx: Option<usize>,
    /// At most this many levels.
    pub max_levels: usize,
    /// Score a window needs to be a hit (scores are sums of ±α; the soft cascade rejects at
    /// the model's `casc_thr`).
    pub hit_threshold: f32,
    /// Suppression.
    pub nms: NmsMethod,
}

impl Default for AcfOptions {
    fn default() -> Self {
        Self {
            upsample: 1.0,
            approx: None,
            max_levels: 64,
            hit_threshold: 0.0,
            nms: NmsMethod::Greedy { iou: 0.5 },
        }
    }
}

/// Per-frame statistics.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AcfStats {
    /// Pyramid levels.
    pub levels: usize,
    /// Windows scored.
    pub windows: usize,
    /// Trees evaluated over all windows (the soft cascade's saving shows against
    /// `windows · trees`).
    pub trees_evaluated: u64,
    /// Windows at or above the hit threshold.
    pub hits: usize,
    /// Channel pyramid (wall time).
    pub channels: Duration,
    /// Scoring (wall time).
    pub score: Duration,
    /// NMS.
    pub nms: Duration,
    /// Whole call.
    pub total: Duration,
}

/// The trees of one level in the scoring form: feature indices turned into offsets into the
/// level's planar channels (relative to the window's top-left block).
enum LevelTrees<'a> {
    /// Every tree of depth ≤ 2: the packed form of the SIMD kernels.
    Packed(PackedTrees),
    /// Some deeper tree: the flattened nodes, walked one window at a time.
    General {
        starts: &'a [u32],
        child: &'a [u32],
        thr: &'a [f32],
        hs: &'a [f32],
        off: Vec<u32>,
    },
}

/// The scores and trees evaluated of every window of one level, row-major (`nx` per row).
struct LevelScores {
    nx: usize,
    scores: Vec<f32>,
    counts: Vec<u32>,
}

/// The ACF detector: a validated model and options.
#[derive(Debug, Clone)]
pub struct AcfDetector {
    model: AcfModel,
    opts: AcfOptions,
    spec: ChannelSpec,
    pyr: PyramidOptions,
    /// Rejection threshold after each tree: the model's trace, or its constant threshold.
    reject: Vec<f32>,
    /// Every tree completed to depth 2 with feature indices in `off` (`None`: a deeper tree).
    packed: Option<Vec<Tree2>>,
    // flattened trees: node k of tree t is starts[t] + k; child indices absolute (0 = leaf)
    starts: Vec<u32>,
    fid: Vec<u32>,
    child: Vec<u32>,
    thr: Vec<f32>,
    hs: Vec<f32>,
}

/// `t` completed to depth 2 ([`Tree2`], feature indices in `off`), or `None` if it is deeper.
/// A leaf above depth 2 becomes a split (on feature 0, threshold 0) whose children both carry
/// its value, so the output is the same whichever way the split goes.
fn pack_tree(t: &Tree) -> Option<Tree2> {
    let leaf = |k: usize| t.child[k] == 0;
    let mut p = Tree2::default();
    if leaf(0) {
        p.hs = [t.hs[0]; 4];
        return Some(p);
    }
    p.off[0] = t.fid[0];
    p.thr[0] = t.thr[0];
    let c = t.child[0] as usize;
    for (side, k) in [c, c + 1].into_iter().enumerate() {
        if leaf(k) {
            p.hs[2 * side] = t.hs[k];
            p.hs[2 * side + 1] = t.hs[k];
        } else {
            let g = t.child[k] as usize;
            if !leaf(g) || !leaf(g + 1) {
                return None;
            }
            p.off[1 + side] = t.fid[k];
            p.thr[1 + side] = t.thr[k];
            p.hs[2 * side] = t.hs[g];
            p.hs[2 * side + 1] = t.hs[g + 1];
        }
    }
    Some(p)
}

impl AcfDetector {
    /// Validate `model` and `opts`.
    pub fn new(model: AcfModel, opts: &AcfOptions) -> Result<Self, AcfError> {
        model.validate("(in memory)")?;
        let spec = ChannelSpec::new(model.channels)?;
        let pyr = PyramidOptions {
            upsample: opts.upsample,
            approx: opts.approx.unwrap_or(model.pyramid.approx),
            max_levels: opts.max_levels,
            min_size: (model.win_width, model.win_height),
            ..model.pyramid
        };
        let (mut starts, mut fid, mut child, mut thr, mut hs) = (vec![], vec![], vec![], vec![], vec![]);
        for t in &model.classifier.trees {
            let s = fid.len() as u32;
            starts.push(s);
            fid.extend_from_slice(&t.fid);
            child.extend(t.child.iter().map(|&c| if c == 0 { 0 } else { c + s }));
            thr.extend_from_slice(&t.thr);
            hs.extend_from_slice(&t.hs);
        }
        let reject = match &model.casc_trace {
            Some(t) => t.clone(),
            None => vec![model.casc_thr; model.classifier.trees.len()],
        };
        let packed = model.classifier.trees.iter().map(pack_tree).collect();
        Ok(Self {
            model,
            opts: *opts,
            spec,
            pyr,
            reject,
            packed,
            starts,
            fid,
            child,
            thr,
            hs,
        })
    }

    /// The model.
    pub fn model(&self) -> &AcfModel {
        &self.model
    }

    /// The pyramid options in use.
    pub fn pyramid_options(&self) -> &PyramidOptions {
        &self.pyr
    }

    /// The channel pyramid of `input`.
    pub fn pyramid(&self, input: &ChannelInput) -> Result<ChannelPyramid, AcfError> {
        Ok(pyramid(input, &self.spec, &self.pyr)?)
    }

    /// Offset of feature `f` of a window in a level of `w x h` blocks.
    fn offset(&self, f: u32, w: usize, h: usize) -> u32 {
        let (ww, wh) = self.model.window_blocks();
        let f = f as usize;
        let (c, rest) = (f / (ww * wh), f % (ww * wh));
        let (y, x) = (rest / ww, rest % ww);
        ((c * h + y) * w + x) as u32
    }

    fn level_trees(&self, ch: &Channels) -> LevelTrees<'_> {
        let (w, h) = (ch.width(), ch.height());
        match &self.packed {
            Some(p) => LevelTrees::Packed(PackedTrees::new(
                p.iter()
                    .map(|t| Tree2 {
                        off: t.off.map(|f| self.offset(f, w, h)),
                        ..*t
                    })
                    .collect(),
            )),
            None => LevelTrees::General {
                starts: &self.starts,
                child: &self.child,
                thr: &self.thr,
                hs: &self.hs,
                off: self.fid.iter().map(|&f| self.offset(f, w, h)).collect(),
            },
        }
    }

    /// Soft-cascade score of the window whose first value is `data[base]` through the general
    /// (deeper) trees, and the trees evaluated.
    #[allow(clippy::too_many_arguments)]
    fn score_general(
        &self,
        starts: &[u32],
        child: &[u32],
        thr: &[f32],
        hs: &[f32],
        off: &[u32],
        data: &[f32],
        base: usize,
    ) -> (f32, u32) {
        let mut h = 0.0f32;
        let mut n = 0;
        for (&s, &r) in starts.iter().zip(&self.reject) {
            let mut k = s as usize;
            while child[k] != 0 {
                let c = child[k] as usize;
                k = c + goes_right(data[base + off[k] as usize], thr[k]) as usize;
            }
            h += hs[k];
            n += 1;
            if h <= r {
                break;
            }
        }
        (h, n)
    }

    /// Scores and trees evaluated of every window of one level (rows in parallel, each row the
    /// same arithmetic for any thread count); `None` if the level is smaller than the window.
    fn score_windows(&self, ch: &Channels) -> Option<LevelScores> {
        let (ww, wh) = self.model.window_blocks();
        if ch.width() < ww || ch.height() < wh {
            return None;
        }
        let (nx, ny) = (ch.width() - ww + 1, ch.height() - wh + 1);
        let lt = self.level_trees(ch);
        let data = ch.as_slice();
        let isa = crate::kernels::isa();
        let mut scores = vec![0.0f32; nx * ny];
        let mut counts = vec![0u32; nx * ny];
        scores
            .par_chunks_mut(nx)
            .zip(counts.par_chunks_mut(nx))
            .enumerate()
            .for_each(|(by, (s, c))| {
                let base = by * ch.width();
                match &lt {
                    LevelTrees::Packed(t) => score_run(isa, t, &self.reject, data, base, s, c),
                    LevelTrees::General {
                        starts,
                        child,
                        thr,
                        hs,
                        off,
                    } => {
                        for (bx, (s, c)) in s.iter_mut().zip(c.iter_mut()).enumerate() {
                            (*s, *c) = self.score_general(starts, child, thr, hs, off, data, base + bx);
                        }
                    }
                }
            });
        Some(LevelScores { nx, scores, counts })
    }

    /// Whether a window that evaluated `count` trees and scored `s` survived the soft cascade.
    fn survived(&self, s: f32, count: u32) -> bool {
        match self.reject.last() {
            Some(&r) => count as usize == self.reject.len() && s > r,
            None => true,
        }
    }

    /// Scores of every window of one level, row by row (`(bx, by, score)`), and the trees
    /// evaluated. A window the soft cascade rejects scores `f32::MIN` (`REJECTED`): it is no detection at
    /// any threshold.
    pub fn score_level(&self, ch: &Channels) -> (Vec<(usize, usize, f32)>, u64) {
        let Some(l) = self.score_windows(ch) else {
            return (vec![], 0);
        };
        let trees = l.counts.iter().map(|&c| c as u64).sum();
        let out = l
            .scores
            .iter()
            .zip(&l.counts)
            .enumerate()
            .map(|(i, (&s, &c))| {
                let s = if self.survived(s, c) { s } else { REJECTED };
                (i % l.nx, i / l.nx, s)
            })
            .collect();
        (out, trees)
    }

    /// Call `f(level, channels, bx, by, score)` for every window of every level of `input`'s
    /// pyramid (levels in order, windows row by row): hard-negative mining and the window
    /// evaluation.
    pub fn for_each_window(
        &self,
        input: &ChannelInput,
        mut f: impl FnMut(usize, &Channels, usize, usize, f32),
    ) -> Result<(), AcfError> {
        let p = self.pyramid(input)?;
        for (i, l) in p.levels.iter().enumerate() {
            let (scores, _) = self.score_level(&l.channels);
            for (bx, by, s) in scores {
                f(i, &l.channels, bx, by, s);
            }
        }
        Ok(())
    }

    /// Detections before suppression: every window scoring at least the hit threshold, as
    /// frame boxes; and the statistics.
    pub fn detect_raw(&self, input: &ChannelInput) -> Result<(Vec<Detection>, AcfStats), AcfError> {
        let t0 = Instant::now();
        let p = self.pyramid(input)?;
        let mut st = AcfStats {
            levels: p.levels.len(),
            channels: t0.elapsed(),
            ..AcfStats::default()
        };
        let t1 = Instant::now();
        let mut dets = Vec::new();
        for l in &p.levels {
            let Some(ls) = self.score_windows(&l.channels) else {
                continue;
            };
            st.windows += ls.scores.len();
            st.trees_evaluated += ls.counts.iter().map(|&c| c as u64).sum::<u64>();
            for (i, (&s, &c)) in ls.scores.iter().zip(&ls.counts).enumerate() {
                let (bx, by) = (i % ls.nx, i / ls.nx);
                if s >= self.opts.hit_threshold && self.survived(s, c) {
                    dets.push(Detection {
                        x: (bx * SHRINK) as f32 / l.scale_x as f32,
                        y: (by * SHRINK) as f32 / l.scale_y as f32,
                        width: self.model.win_width as f32 / l.scale_x as f32,
                        height: self.model.win_height as f32 / l.scale_y as f32,
                        score: s,
                    });
                }
            }
        }
        st.hits = dets.len();
        st.score = t1.elapsed();
        st.total = t0.elapsed();
        Ok((dets, st))
    }

    /// Detect: [`AcfDetector::detect_raw`] then the suppression.
    pub fn detect(&self, input: &ChannelInput) -> Result<(Vec<Detection>, AcfStats), AcfError> {
        let t0 = Instant::now();
        let (raw, mut st) = self.detect_raw(input)?;
        let t1 = Instant::now();
        let out = match self.opts.nms {
            NmsMethod::None => raw,
            NmsMethod::Greedy { iou } => greedy_nms(&raw, iou),
            NmsMethod::Group { threshold, eps } => group_rectangles(&raw, threshold, eps),
        };
        st.nms = t1.elapsed();
        st.total = t0.elapsed();
        Ok((out, st))
    }

    /// Score of a window's feature vector (e.g. a training positive) with the soft cascade:
    /// `REJECTED` when the cascade rejects it (as [`AcfDetector::score_level`]).
    pub fn score_features(&self, x: &[f32]) -> f32 {
        let (s, n) = self.model.classifier.score_trace(x, &self.reject);
        if self.survived(s, n as u32) {
            s
        } else {
            REJECTED
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::channels::channels;
    use crate::image::Image;
    use crate::raw::Cfa;

    /// A model with one stump on channel `c` at window block (x, y).
    fn stump_model(c: usize, x: usize, y: usize, thr: f32) -> AcfModel {
        let (ww, wh) = (16, 32);
        AcfModel {
            format: FORMAT.into(),
            version: VERSION,
            domain: Domain::Mosaic,
            win_width: 64,
            win_height: 128,
            channels: ChannelOptions::default(),
            features: FeatureSet::All,
            pyramid: PyramidOptions::default(),
            casc_thr: CASC_THR,
            casc_cal: 0.0,
            casc_trace: None,
            mosaic_tone: MosaicTone::Linear,
            boost: BoostOptions::default(),
            classifier: BoostedTrees {
                n_features: N_CHANNELS * ww * wh,
                trees: vec![Tree {
                    fid: vec![((c * wh + y) * ww + x) as u32, 0, 0],
                    thr: vec![thr, 0.0, 0.0],
                    child: vec![1, 0, 0],
                    hs: vec![0.0, -1.0, 1.0],
                }],
            },
            provenance: serde_json::json!({"test": true}),
        }
    }

    #[test]
    fn level_scores_equal_the_window_features_scores() {
        let img = Image::from_fn(96, 160, |x, y| ((x * 7 + y * 3 + x * y / 5) % 256) as f32);
        let input = ChannelInput::Mosaic {
            image: img.view(),
            cfa: Cfa::Rggb,
        };
        let m = stump_model(5, 3, 9, 0.02);
        let det = AcfDetector::new(m, &AcfOptions::default()).unwrap();
        let ch = channels(&input, &ChannelSpec::default()).unwrap();
        let (scores, trees) = det.score_level(&ch);
        assert_eq!(scores.len(), (24 - 16 + 1) * (40 - 32 + 1));
        assert_eq!(trees, scores.len() as u64);
        for &(bx, by, s) in &scores {
            let f = ch.window(bx, by, 16, 32).unwrap();
            assert_eq!(s, det.score_features(&f));
            assert_eq!(
                s,
                if ch.get(5, bx + 3, by + 9) < 0.02 {
                    -1.0
                } else {
                    1.0
                }
            );
        }
    }

    #[test]
    fn model_file_round_trip_and_validation() {
        let m = stump_model(0, 0, 0, 0.5);
        let back = AcfModel::from_json(&m.to_json(), "test").unwrap();
        assert_eq!(back, m);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("acf.json");
        m.save(&p).unwrap();
        assert!(is_acf_model_file(&p));
        assert_eq!(AcfModel::load(&p).unwrap(), m);
        let mut bad = m.clone();
        bad.win_width = 60;
        assert!(matches!(bad.validate("x"), Err(AcfError::Invalid { .. })));
        let mut bad = m.clone();
        bad.classifier.trees[0].fid[0] = 999_999;
        assert!(matches!(bad.validate("x"), Err(AcfError::Boost(_))));
        let hog = dir.path().join("hog.json");
        std::fs::write(&hog, r#"{"format":"mosaicd-hog-svm"}"#).unwrap();
        assert!(!is_acf_model_file(&hog));
    }

    #[test]
    fn feature_set_is_written_only_when_not_all_and_validated() {
        // the default is not written: a file from before the option reads as `all`
        let m = stump_model(0, 0, 0, 0.5);
        let text = m.to_json();
        assert!(!text.contains("\"features\""), "{text}");
        assert_eq!(
            AcfModel::from_json(&text, "test").unwrap().features,
            FeatureSet::All
        );
        // a gradient model round-trips with the key
        let mut g = stump_model(MAG_CHANNEL + 2, 3, 4, 0.1);
        g.features = FeatureSet::Gradient;
        let text = g.to_json();
        assert!(text.contains("\"features\":\"gradient\""), "{text}");
        assert_eq!(AcfModel::from_json(&text, "test").unwrap(), g);
        // a gradient model reading a colour feature is refused, naming tree, node and channel;
        // the last colour feature and the first gradient one are the boundary
        for (c, x, y, ok) in [(0, 0, 0, false), (2, 15, 31, false), (MAG_CHANNEL, 0, 0, true)] {
            let mut b = stump_model(c, x, y, 0.5);
            b.features = FeatureSet::Gradient;
            match b.validate("x") {
                Ok(()) => assert!(ok, "channel {c} accepted"),
                Err(AcfError::Invalid { what, .. }) => {
                    assert!(!ok, "{what}");
                    assert!(what.contains("tree 0 node 0 reads feature"), "{what}");
                    assert!(what.ends_with(&format!("of channel {c}")), "{what}");
                }
                Err(e) => panic!("{e}"),
            }
        }
        assert_eq!(FeatureSet::Gradient.first_channel(), MAG_CHANNEL);
        assert_eq!(FeatureSet::All.first_channel(), 0);
    }

    #[test]
    fn shipped_models_read_and_write_back_unchanged() {
        // the shipped files predate `features`: they load as `all` and serialise to the same JSON
        for f in ["acf-mosaic.json", "acf-colour.json"] {
            let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("models").join(f);
            let text = std::fs::read_to_string(&p).unwrap();
            let m = AcfModel::load(&p).unwrap();
            assert_eq!(m.features, FeatureSet::All, "{f}");
            let want: serde_json::Value = serde_json::from_str(&text).unwrap();
            let got: serde_json::Value = serde_json::from_str(&m.to_json()).unwrap();
            assert!(got == want, "{f} changed when written back");
        }
    }

    #[test]
    fn boxes_map_back_to_the_frame() {
        // A stump that always fires (threshold above any value): one box per window.
        let img = Image::filled(128, 256, [90u8, 120, 60]);
        let input = ChannelInput::Rgb8(img.view());
        let det = AcfDetector::new(
            stump_model(0, 0, 0, 1e9),
            &AcfOptions {
                nms: NmsMethod::None,
                ..AcfOptions::default()
            },
        )
        .unwrap();
        let (dets, st) = det.detect(&input).unwrap();
        // −1 everywhere (x < thr → left → −1): below the cascade threshold? −1 ≤ −1: rejected
        assert!(dets.is_empty());
        assert_eq!(st.hits, 0);
        let det = AcfDetector::new(
            stump_model(0, 0, 0, -1e9),
            &AcfOptions {
                nms: NmsMethod::None,
                ..AcfOptions::default()
            },
        )
        .unwrap();
        let (dets, st) = det.detect(&input).unwrap();
        assert_eq!(dets.len(), st.windows);
        // level 0: 17 x 33 windows of 64x128 at 4-pixel steps
        let l0: Vec<&Detection> = dets.iter().filter(|d| d.width == 64.0).collect();
        assert_eq!(l0.len(), 17 * 33);
        assert!(dets
            .iter()
            .all(|d| d.x >= 0.0 && d.x + d.width <= 128.5 && d.y + d.height <= 256.5));
    }
}
