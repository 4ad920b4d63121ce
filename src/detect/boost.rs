//! Boosted decision trees with a soft cascade (Dollár's `binaryTreeTrain`, `adaBoostTrain`,
//! `acfDetect`): the classifier of the ACF detector.
//!
//! # Overview
//!
//! A window's score is the sum of `T` small decision trees, each reading a few single features
//! (one aggregated channel value each). Scoring stops as soon as the running sum falls to the
//! soft-cascade threshold, so most windows of an image are rejected after a few trees.
//!
//! ```
//! use mosaicd::detect::{train_adaboost, BoostOptions, TreeOptions};
//! // Two features; positives have a large feature 1.
//! let neg: Vec<Vec<f32>> = (0..50).map(|i| vec![i as f32, (i % 7) as f32]).collect();
//! let pos: Vec<Vec<f32>> = (0..50).map(|i| vec![i as f32, 10.0 + (i % 5) as f32]).collect();
//! let o = BoostOptions { n_weak: 4, ..BoostOptions::default() };
//! let model = train_adaboost(&neg, &pos, &o, &mut |_| {}).unwrap();
//! assert!(model.score(&pos[3], f32::NEG_INFINITY) > 0.0);
//! assert!(model.score(&neg[3], f32::NEG_INFINITY) < 0.0);
//! ```
//!
//! # The math
//!
//! **Quantisation.** Training quantises feature `f` to `q = round((x − m_f)/δ_f)` in
//! `0..nBins`, `m_f = min − 0.01`, `δ_f = (max − min + 0.02)/(nBins − 1)` over the training set.
//!
//! **Trees.** A node holding samples with weights `w` (normalised to 1 at the root) has prior
//! `p = Σw⁺ / Σw` and value `h = clamp(½ ln(p/(1 − p)), −4, 4)`. It is split unless `p < 10⁻³`,
//! `p > 1 − 10⁻³`, its depth is the maximum or `Σw < minWeight`: for every feature (or a seeded
//! random fraction `fracFtrs` of them, drawn per node) and every bin `t`, the weighted error of
//! the stump `q ≤ t` is `e(t) = p − C⁺(t) + C⁻(t)` (node-normalised cumulative weights) or
//! `1 − e(t)` for the opposite polarity; the smallest wins (ties: the first feature, the first
//! bin). The stored threshold is `θ = m_f + δ_f (t + ½)`; a sample goes left when `x < θ`.
//! The tree's error is `ε = Σ_leaves min(p, 1 − p) Σw`.
//!
//! **Discrete AdaBoost** (our default, as Dollár's `acfTrain`): a tree outputs the sign of its
//! leaf value times `α = clamp(½ ln((1 − ε)/ε), −5, 5)`. **Real AdaBoost** (`discrete: false`):
//! the leaf value itself, `α = 1`. After each tree `H ← H + h(x)` and the weights become
//! `w⁻ = e^{H}/2N⁻`, `w⁺ = e^{−H}/2N⁺`. We use discrete: the soft-cascade threshold −1 and the
//! calibration 0.005 are Dollár's values for discrete scores (each tree adds ±α, α up to 5), and
//! his INRIA result was obtained with it. Real AdaBoost is kept as an option for experiments.
//!
//! **Soft cascade** (Dollár's constant rejection threshold): leaf values get `+cascCal` (0.005)
//! after training; while scoring, `H_k = Σ_{j ≤ k} h_j(x)`, and the window is rejected as soon as
//! `H_k ≤ cascThr` (−1). A window that survives every tree scores `H_T`.
//!
//! **Calibrated rejection trace** (Bourdev & Brandt's per-tree trace, set as in Zhang & Viola's
//! direct backward pruning; [`calibrate_trace`]): the window is rejected after tree `k` when
//! `H_k ≤ r_k`. Given the running scores `H_k(x_i)` of calibration positives (held out from the
//! classifier's training: a classifier's own training positives run far higher than new ones),
//! a floor `κ` (the lowest final score a detection may have), a loss fraction `f` and a margin
//! `δ ≥ 0`:
//!
//! ```text
//! K  = { i : H_T(x_i) ≥ κ }                      the positives that are detections at κ
//! K' = K without the ⌊f·|K|⌋ members of lowest min_k H_k(x_i)   (the deepest dips)
//! r_k = (min_{i ∈ K'} H_k(x_i) − δ)⁻              (⁻: the next float below)
//! ```
//!
//! No member of `K'` is rejected (each stays strictly above `r_k`), so at most a fraction `f` of
//! the calibration positives that reach `κ` are lost. `r_T ≥ κ − δ`: with a trace, windows
//! scoring below about `κ` are not detections. With the constant threshold the running score of a
//! positive must never dip to `cascThr`; with the trace it must only stay above the lowest running
//! score that the calibration positives reached after the same number of trees.
//!
//! # Determinism
//! Each feature's best split is computed sequentially over the samples in a fixed order (f64
//! sums) and the features' results are compared in index order, so the trees are identical for
//! any thread count. The feature subsets come from a seeded ChaCha8 stream.
//!
//! # References
//! P. Dollár et al., "Fast Feature Pyramids for Object Detection", PAMI 2014; R. Appel, T. Fuchs,
//! P. Dollár, P. Perona, "Quickly Boosting Decision Trees", ICML 2013; L. Bourdev, J. Brandt,
//! "Robust Object Detection via Soft Cascade", CVPR 2005; Piotr's toolbox (`binaryTreeTrain`,
//! `adaBoostTrain`, `acfDetect`).

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Leaf values are clamped to ±this (Dollár's).
const MAX_LEAF: f64 = 4.0;
/// Discrete AdaBoost's α is clamped to ±this (Dollár's).
const MAX_ALPHA: f64 = 5.0;
/// Nodes purer than this are not split.
const PURE: f64 = 1e-3;

/// Errors from boosting and from trees.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BoostError {
    /// An option out of range.
    #[error("boost option {name} = {value}: {allowed}")]
    BadOption {
        /// Option.
        name: &'static str,
        /// Offending value.
        value: String,
        /// What is allowed.
        allowed: &'static str,
    },
    /// No positives or no negatives.
    #[error("training needs positives and negatives, got {positives} and {negatives}")]
    NoData {
        /// Positives.
        positives: usize,
        /// Negatives.
        negatives: usize,
    },
    /// Samples of different lengths.
    #[error("sample {index} has {got} features, expected {expected}")]
    FeatureCount {
        /// Sample (negatives first, then positives).
        index: usize,
        /// Its length.
        got: usize,
        /// The first sample's length.
        expected: usize,
    },
    /// A feature value that is not finite.
    #[error("sample {index}, feature {feature} is {value}")]
    NotFinite {
        /// Sample.
        index: usize,
        /// Feature.
        feature: usize,
        /// Value.
        value: f32,
    },
    /// A tree that reads a feature the window does not have, or links outside itself.
    #[error("tree {tree}: {what}")]
    BadTree {
        /// Tree index.
        tree: usize,
        /// What is wrong.
        what: String,
    },
}

/// Tree options (Dollár's `pTree`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TreeOptions {
    /// Maximum depth (2: three stumps, four leaves).
    pub max_depth: usize,
    /// Quantisation bins (≤ 256).
    pub n_bins: usize,
    /// Nodes with less (root-normalised) weight are not split.
    pub min_weight: f64,
    /// Fraction of the features tried at each node (Dollár's INRIA demo: 1/16).
    pub frac_features: f64,
}

impl Default for TreeOptions {
    fn default() -> Self {
        Self {
            max_depth: 2,
            n_bins: 256,
            min_weight: 0.01,
            frac_features: 1.0 / 16.0,
        }
    }
}

/// Boosting options (Dollár's `pBoost`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoostOptions {
    /// Tree options.
    pub tree: TreeOptions,
    /// Number of trees.
    pub n_weak: usize,
    /// Discrete AdaBoost (true, Dollár's) or Real AdaBoost.
    pub discrete: bool,
    /// Seed of the per-node feature sampling.
    pub seed: u64,
}

impl Default for BoostOptions {
    fn default() -> Self {
        Self {
            tree: TreeOptions::default(),
            n_weak: 128,
            discrete: true,
            seed: 0,
        }
    }
}

impl BoostOptions {
    fn check(&self) -> Result<(), BoostError> {
        let bad = |name, value: String, allowed| Err(BoostError::BadOption { name, value, allowed });
        let t = &self.tree;
        if !(1..=8).contains(&t.max_depth) {
            return bad("max_depth", t.max_depth.to_string(), "1..=8");
        }
        if !(2..=256).contains(&t.n_bins) {
            return bad("n_bins", t.n_bins.to_string(), "2..=256");
        }
        if !(t.frac_features > 0.0 && t.frac_features <= 1.0) {
            return bad("frac_features", t.frac_features.to_string(), "in (0, 1]");
        }
        if !(t.min_weight.is_finite() && t.min_weight >= 0.0) {
            return bad("min_weight", t.min_weight.to_string(), "finite and ≥ 0");
        }
        if self.n_weak == 0 || self.n_weak > 100_000 {
            return bad("n_weak", self.n_weak.to_string(), "1..=100000");
        }
        Ok(())
    }
}

/// One decision tree: node 0 is the root; a node with `child[k] = 0` is a leaf, otherwise its
/// children are `child[k]` (taken when `x[fid[k]] < thr[k]`) and `child[k] + 1`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tree {
    /// Feature of each node.
    pub fid: Vec<u32>,
    /// Threshold of each node.
    pub thr: Vec<f32>,
    /// Left child of each node (0: leaf).
    pub child: Vec<u32>,
    /// Value of each node (what a leaf adds to the score).
    pub hs: Vec<f32>,
}

impl Tree {
    /// The tree's output for features read by `x`.
    #[inline]
    pub fn apply(&self, x: impl Fn(usize) -> f32) -> f32 {
        let mut k = 0usize;
        while self.child[k] != 0 {
            let c = self.child[k] as usize;
            k = if x(self.fid[k] as usize) < self.thr[k] {
                c
            } else {
                c + 1
            };
        }
        self.hs[k]
    }
}

/// Boosted trees: the classifier.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoostedTrees {
    /// Features per window.
    pub n_features: usize,
    /// The trees, in boosting order.
    pub trees: Vec<Tree>,
}

impl BoostedTrees {
    /// Check that every tree is well formed and reads features `< n_features`.
    pub fn validate(&self) -> Result<(), BoostError> {
        for (i, t) in self.trees.iter().enumerate() {
            let n = t.fid.len();
            let bad = |what: String| Err(BoostError::BadTree { tree: i, what });
            if n == 0 || t.thr.len() != n || t.child.len() != n || t.hs.len() != n {
                return bad(format!(
                    "node arrays differ in length or are empty: fid {}, thr {}, child {}, hs {}",
                    n,
                    t.thr.len(),
                    t.child.len(),
                    t.hs.len()
                ));
            }
            for k in 0..n {
                let c = t.child[k] as usize;
                if c != 0 && (c <= k || c + 1 >= n) {
                    return bad(format!("node {k} links to child {c} of {n} nodes"));
                }
                if c != 0 && t.fid[k] as usize >= self.n_features {
                    return bad(format!(
                        "node {k} reads feature {} of {}",
                        t.fid[k], self.n_features
                    ));
                }
                if !t.hs[k].is_finite() || (c != 0 && t.thr[k].is_nan()) {
                    return bad(format!(
                        "node {k} has a value {} or threshold {}",
                        t.hs[k], t.thr[k]
                    ));
                }
            }
        }
        Ok(())
    }

    /// Soft-cascade score of a feature vector: stops (returning the running sum) as soon as it
    /// is `≤ casc_thr` (`f32::NEG_INFINITY`: every tree).
    pub fn score(&self, x: &[f32], casc_thr: f32) -> f32 {
        self.score_with(|f| x[f], casc_thr)
    }

    /// [`BoostedTrees::score`] with features read by `x`.
    #[inline]
    pub fn score_with(&self, x: impl Fn(usize) -> f32 + Copy, casc_thr: f32) -> f32 {
        let mut h = 0.0f32;
        for t in &self.trees {
            h += t.apply(x);
            if h <= casc_thr {
                break;
            }
        }
        h
    }

    /// The running scores `H_1 … H_T` of a feature vector (every tree, no rejection).
    pub fn running_scores(&self, x: &[f32]) -> Vec<f32> {
        let mut h = 0.0f32;
        self.trees
            .iter()
            .map(|t| {
                h += t.apply(|f| x[f]);
                h
            })
            .collect()
    }

    /// Soft-cascade score with a per-tree rejection threshold `reject[k]` (one per tree): stops
    /// after tree `k` when the running sum is `≤ reject[k]`. Returns the score and the trees
    /// evaluated.
    pub fn score_trace(&self, x: &[f32], reject: &[f32]) -> (f32, usize) {
        let mut h = 0.0f32;
        for (k, (t, &r)) in self.trees.iter().zip(reject).enumerate() {
            h += t.apply(|f| x[f]);
            if h <= r {
                return (h, k + 1);
            }
        }
        (h, self.trees.len().min(reject.len()))
    }

    /// Add `cal` to every node value (Dollár's `cascCal`).
    pub fn calibrate(&mut self, cal: f32) {
        for t in &mut self.trees {
            t.hs.iter_mut().for_each(|h| *h += cal);
        }
    }
}

/// Options of `calibrate_trace` (see the module docs for the rule).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TraceOptions {
    /// Floor `κ`: only calibration positives whose final score reaches it are protected (the
    /// lowest final score a detection is expected to have).
    pub floor: f32,
    /// Fraction `f` of the protected positives the trace may reject (those whose running score
    /// dips lowest).
    pub loss: f64,
    /// Margin `δ ≥ 0` subtracted from the trace (room for positives unlike the calibration set).
    pub margin: f32,
}

impl Default for TraceOptions {
    /// κ = −10, f = 0, δ = 1 (chosen on the inner split of fold 0: docs/acf.md).
    fn default() -> Self {
        Self {
            floor: -10.0,
            loss: 0.0,
            margin: 1.0,
        }
    }
}

/// A per-tree rejection trace from the running scores `runs[i][k] = H_{k+1}(x_i)` of calibration
/// positives (all of the same length, one per tree; see the module docs).
pub(crate) fn calibrate_trace(runs: &[Vec<f32>], o: &TraceOptions) -> Result<Vec<f32>, BoostError> {
    let bad = |name, value: String, allowed| Err(BoostError::BadOption { name, value, allowed });
    if !(0.0..1.0).contains(&o.loss) {
        return bad("trace loss", o.loss.to_string(), "in [0, 1)");
    }
    if !(o.margin.is_finite() && o.margin >= 0.0) {
        return bad("trace margin", o.margin.to_string(), "finite and ≥ 0");
    }
    if !o.floor.is_finite() {
        return bad("trace floor", o.floor.to_string(), "finite");
    }
    let t = runs.first().map_or(0, |r| r.len());
    if let Some(i) = runs.iter().position(|r| r.len() != t) {
        return Err(BoostError::FeatureCount {
            index: i,
            got: runs[i].len(),
            expected: t,
        });
    }
    // the protected positives, deepest dip first (ties: by index)
    let mut keep: Vec<(f32, usize)> = runs
        .iter()
        .enumerate()
        .filter(|(_, r)| r.last().is_some_and(|&h| h >= o.floor))
        .map(|(i, r)| (r.iter().copied().fold(f32::INFINITY, f32::min), i))
        .collect();
    if keep.is_empty() || t == 0 {
        return Err(BoostError::NoData {
            positives: keep.len(),
            negatives: 0,
        });
    }
    keep.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let drop = (o.loss * keep.len() as f64).floor() as usize;
    let kept = &keep[drop.min(keep.len() - 1)..];
    Ok((0..t)
        .map(|k| {
            let low = kept
                .iter()
                .map(|&(_, i)| runs[i][k])
                .fold(f32::INFINITY, f32::min);
            (low - o.margin).next_down()
        })
        .collect())
}

/// Training data quantised feature-major: `q[f · n + i]`.
struct Quantised {
    n: usize,
    q: Vec<u8>,
    x_min: Vec<f32>,
    x_step: Vec<f32>,
}

fn quantise(rows: &[&[f32]], n_features: usize, n_bins: usize) -> Quantised {
    let n = rows.len();
    let (x_min, x_step): (Vec<f32>, Vec<f32>) = (0..n_features)
        .into_par_iter()
        .map(|f| {
            let (lo, hi) = rows
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), r| {
                    (lo.min(r[f]), hi.max(r[f]))
                });
            let (lo, hi) = (lo - 0.01, hi + 0.01);
            (lo, (hi - lo) / (n_bins - 1) as f32)
        })
        .unzip();
    let mut q = vec![0u8; n_features * n];
    let top = (n_bins - 1) as f32;
    q.par_chunks_mut(n).enumerate().for_each(|(f, col)| {
        let inv = 1.0 / x_step[f];
        for (c, r) in col.iter_mut().zip(rows) {
            *c = ((r[f] - x_min[f]) * inv).round().clamp(0.0, top) as u8;
        }
    });
    Quantised { n, q, x_min, x_step }
}

/// The best stump of one feature on the samples `idx` (normalised weights `w`, labels `pos`):
/// (error, bin).
fn best_stump(
    col: &[u8],
    idx: &[u32],
    w: &[f64],
    pos: &[bool],
    prior: f64,
    n_bins: usize,
    hist: &mut [[f64; 2]; 256],
) -> (f64, usize) {
    hist[..n_bins].iter_mut().for_each(|h| *h = [0.0; 2]);
    for &i in idx {
        let i = i as usize;
        hist[col[i] as usize][pos[i] as usize] += w[i];
    }
    let (mut c0, mut c1) = (0.0f64, 0.0f64);
    let mut best = (prior.min(1.0 - prior), 0usize);
    for (t, h) in hist[..n_bins - 1].iter().enumerate() {
        c0 += h[0];
        c1 += h[1];
        let e = prior - c1 + c0;
        let e = e.min(1.0 - e);
        if e < best.0 - 1e-12 {
            best = (e, t);
        }
    }
    best
}

/// Train one tree on the quantised data with weights `w` (any positive scale); returns the tree
/// (thresholds in feature units) and its weighted error.
fn train_tree(
    data: &Quantised,
    pos: &[bool],
    w: &[f64],
    o: &TreeOptions,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> (Tree, f64) {
    let n_features = data.x_min.len();
    let total: f64 = w.iter().sum();
    let w: Vec<f64> = w.iter().map(|v| v / total).collect();
    let mut tree = Tree {
        fid: vec![],
        thr: vec![],
        child: vec![],
        hs: vec![],
    };
    let mut nodes: Vec<(Vec<u32>, usize)> = vec![((0..data.n as u32).collect(), 0)];
    let mut err = 0.0;
    let mut k = 0;
    let n_try = ((n_features as f64 * o.frac_features).floor() as usize).clamp(1, n_features);
    let mut all: Vec<u32> = (0..n_features as u32).collect();
    while k < nodes.len() {
        let (idx, depth) = std::mem::take(&mut nodes[k]);
        let (mut w0, mut w1) = (0.0f64, 0.0f64);
        for &i in &idx {
            if pos[i as usize] {
                w1 += w[i as usize];
            } else {
                w0 += w[i as usize];
            }
        }
        let wn = w0 + w1;
        let prior = if wn > 0.0 { w1 / wn } else { 0.5 };
        let h = (0.5 * (prior / (1.0 - prior)).ln()).clamp(-MAX_LEAF, MAX_LEAF);
        tree.fid.push(0);
        tree.thr.push(0.0);
        tree.child.push(0);
        tree.hs.push(if h.is_nan() { 0.0 } else { h as f32 });
        let leaf = |err: &mut f64| *err += prior.min(1.0 - prior) * wn;
        if !(PURE..=1.0 - PURE).contains(&prior) || depth >= o.max_depth || wn < o.min_weight {
            leaf(&mut err);
            k += 1;
            continue;
        }
        let fids: &[u32] = if n_try < n_features {
            let (head, _) = all.partial_shuffle(rng, n_try);
            head.sort_unstable();
            head
        } else {
            &all
        };
        // node-normalised weights for the stump search
        let wl: Vec<f64> = w.iter().map(|v| v / wn).collect();
        let best = fids
            .par_iter()
            .map_init(
                || Box::new([[0.0f64; 2]; 256]),
                |hist, &f| {
                    let col = &data.q[f as usize * data.n..(f as usize + 1) * data.n];
                    let (e, t) = best_stump(col, &idx, &wl, pos, prior, o.n_bins, hist);
                    (e, f, t)
                },
            )
            .collect::<Vec<_>>()
            .into_iter()
            .fold(None::<(f64, u32, usize)>, |b, c| match b {
                Some(b) if b.0 <= c.0 + 1e-12 => Some(b),
                _ => Some(c),
            })
            .expect("at least one feature");
        let (_, f, t) = best;
        let col = &data.q[f as usize * data.n..(f as usize + 1) * data.n];
        let (left, right): (Vec<u32>, Vec<u32>) = idx.iter().partition(|&&i| col[i as usize] as usize <= t);
        if left.is_empty() || right.is_empty() {
            leaf(&mut err);
            k += 1;
            continue;
        }
        tree.fid[k] = f;
        tree.thr[k] = data.x_min[f as usize] + data.x_step[f as usize] * (t as f32 + 0.5);
        tree.child[k] = nodes.len() as u32;
        nodes.push((left, depth + 1));
        nodes.push((right, depth + 1));
        k += 1;
    }
    (tree, err)
}

/// Train boosted trees on negatives `x0` and positives `x1` (Dollár's `adaBoostTrain`);
/// `progress` gets a line every 16 trees. The trees are not calibrated (see
/// [`BoostedTrees::calibrate`]).
pub fn train_adaboost<R: AsRef<[f32]> + Sync>(
    x0: &[R],
    x1: &[R],
    o: &BoostOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<BoostedTrees, BoostError> {
    o.check()?;
    if x0.is_empty() || x1.is_empty() {
        return Err(BoostError::NoData {
            positives: x1.len(),
            negatives: x0.len(),
        });
    }
    let rows: Vec<&[f32]> = x0.iter().chain(x1).map(|r| r.as_ref()).collect();
    let nf = rows[0].len();
    for (i, r) in rows.iter().enumerate() {
        if r.len() != nf {
            return Err(BoostError::FeatureCount {
                index: i,
                got: r.len(),
                expected: nf,
            });
        }
        if let Some(f) = r.iter().position(|v| !v.is_finite()) {
            return Err(BoostError::NotFinite {
                index: i,
                feature: f,
                value: r[f],
            });
        }
    }
    if nf == 0 {
        return Err(BoostError::BadOption {
            name: "features",
            value: "0".into(),
            allowed: "at least one feature per sample",
        });
    }
    let (n0, n1) = (x0.len(), x1.len());
    let pos: Vec<bool> = (0..n0 + n1).map(|i| i >= n0).collect();
    let data = quantise(&rows, nf, o.tree.n_bins);
    let mut h = vec![0.0f64; n0 + n1];
    let mut w: Vec<f64> = (0..n0 + n1)
        .map(|i| if pos[i] { 0.5 / n1 as f64 } else { 0.5 / n0 as f64 })
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(o.seed ^ 0xb0057);
    let mut trees = Vec::with_capacity(o.n_weak);
    for i in 0..o.n_weak {
        let (mut tree, err) = train_tree(&data, &pos, &w, &o.tree, &mut rng);
        let alpha = if o.discrete {
            let e = err.clamp(1e-12, 1.0 - 1e-12);
            tree.hs
                .iter_mut()
                .for_each(|v| *v = if *v > 0.0 { 1.0 } else { -1.0 });
            (0.5 * ((1.0 - e) / e).ln()).clamp(-MAX_ALPHA, MAX_ALPHA)
        } else {
            1.0
        };
        tree.hs.iter_mut().for_each(|v| *v = (*v as f64 * alpha) as f32);
        let out: Vec<f32> = rows.par_iter().map(|r| tree.apply(|f| r[f])).collect();
        let mut loss = 0.0;
        for j in 0..n0 + n1 {
            h[j] += out[j] as f64;
            w[j] = if pos[j] {
                (-h[j]).exp() / (2 * n1) as f64
            } else {
                h[j].exp() / (2 * n0) as f64
            };
            loss += w[j];
        }
        trees.push(tree);
        if (i + 1) % 16 == 0 || i + 1 == o.n_weak {
            progress(&format!(
                "boost: tree {}/{}: alpha {alpha:.3}, error {err:.4}, loss {loss:.3e}",
                i + 1,
                o.n_weak
            ));
        }
        if loss < 1e-40 {
            progress("boost: loss below 1e-40, stopping early");
            break;
        }
    }
    Ok(BoostedTrees {
        n_features: nf,
        trees,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toy(n: usize, seed: u64) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
        use rand::Rng;
        let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        // 20 features; positives: feature 3 high and feature 11 low (an AND a stump cannot do)
        let mut neg = Vec::new();
        let mut pos = Vec::new();
        while neg.len() < n || pos.len() < n {
            let x: Vec<f32> = (0..20).map(|_| r.random_range(0.0..1.0)).collect();
            let p = x[3] > 0.5 && x[11] < 0.5;
            if p && pos.len() < n {
                pos.push(x);
            } else if !p && neg.len() < n {
                neg.push(x);
            }
        }
        (neg, pos)
    }

    #[test]
    fn a_depth_two_tree_learns_an_and() {
        let (neg, pos) = toy(300, 1);
        let o = BoostOptions {
            n_weak: 1,
            tree: TreeOptions {
                frac_features: 1.0,
                ..TreeOptions::default()
            },
            ..BoostOptions::default()
        };
        let m = train_adaboost(&neg, &pos, &o, &mut |_| {}).unwrap();
        m.validate().unwrap();
        let t = &m.trees[0];
        // root on feature 3 or 11, the relevant child on the other
        let mut used: Vec<u32> = t
            .fid
            .iter()
            .zip(&t.child)
            .filter(|(_, &c)| c != 0)
            .map(|(&f, _)| f)
            .collect();
        used.sort();
        used.dedup();
        assert_eq!(used, vec![3, 11], "{t:?}");
        let errors = neg.iter().filter(|x| m.score(x, f32::NEG_INFINITY) > 0.0).count()
            + pos
                .iter()
                .filter(|x| m.score(x, f32::NEG_INFINITY) <= 0.0)
                .count();
        assert!(errors <= 12, "{errors} training errors");
    }

    #[test]
    fn hand_checked_stump() {
        // one feature, negatives 0..4, positives 6..10: the best stump splits between them
        // with zero error; discrete AdaBoost then gives α = 5 (clamped), leaves ±5.
        let neg: Vec<Vec<f32>> = (0..5).map(|i| vec![i as f32]).collect();
        let pos: Vec<Vec<f32>> = (6..11).map(|i| vec![i as f32]).collect();
        let o = BoostOptions {
            n_weak: 1,
            tree: TreeOptions {
                max_depth: 1,
                frac_features: 1.0,
                ..TreeOptions::default()
            },
            ..BoostOptions::default()
        };
        let m = train_adaboost(&neg, &pos, &o, &mut |_| {}).unwrap();
        let t = &m.trees[0];
        assert_eq!(t.child[0], 1);
        assert!(t.thr[0] > 4.0 && t.thr[0] < 6.0, "{}", t.thr[0]);
        assert_eq!((t.hs[1], t.hs[2]), (-5.0, 5.0));
        assert_eq!(
            m.score(&[5.5], f32::NEG_INFINITY),
            if 5.5 < t.thr[0] { -5.0 } else { 5.0 }
        );
    }

    /// A stump on feature 0 at 0.5 adding −v (left) or v (right).
    fn stump(v: f32) -> Tree {
        Tree {
            fid: vec![0, 0, 0],
            thr: vec![0.5, 0.0, 0.0],
            child: vec![1, 0, 0],
            hs: vec![0.0, -v, v],
        }
    }

    #[test]
    fn soft_cascade_stops_early() {
        let m = BoostedTrees {
            n_features: 1,
            trees: vec![stump(0.6), stump(0.6), stump(5.0)],
        };
        m.validate().unwrap();
        // x = 0: −0.6, −1.2 ≤ −1 → stop before the third tree
        assert_eq!(m.score(&[0.0], -1.0), -1.2);
        assert_eq!(m.score(&[0.0], f32::NEG_INFINITY), -6.2);
        assert_eq!(m.score(&[1.0], -1.0), 6.2);
    }

    #[test]
    fn trace_protects_the_kept_positives() {
        // three positives over three trees; the third dips lowest and is the one dropped at 34 %
        let runs = vec![
            vec![0.5f32, 1.0, 3.0],
            vec![-0.5, 0.5, 2.0],
            vec![-2.0, -1.0, 4.0],
            vec![-3.0, -4.0, -1.0], // ends below the floor: not protected
        ];
        let o = TraceOptions {
            floor: 0.0,
            loss: 0.0,
            margin: 0.0,
        };
        let r = calibrate_trace(&runs, &o).unwrap();
        assert_eq!(
            r,
            vec![(-2.0f32).next_down(), (-1.0f32).next_down(), 2.0f32.next_down()]
        );
        let r = calibrate_trace(&runs, &TraceOptions { loss: 0.34, ..o }).unwrap();
        assert_eq!(
            r,
            vec![(-0.5f32).next_down(), 0.5f32.next_down(), 2.0f32.next_down()]
        );
        let r = calibrate_trace(&runs, &TraceOptions { margin: 1.0, ..o }).unwrap();
        assert_eq!(r[0], (-3.0f32).next_down());
        // every kept positive survives the trace when scored
        let m = BoostedTrees {
            n_features: 1,
            trees: vec![stump(1.0), stump(1.0)],
        };
        let runs = vec![m.running_scores(&[1.0]), m.running_scores(&[0.0])];
        assert_eq!(runs[0], vec![1.0, 2.0]);
        let r = calibrate_trace(&runs, &TraceOptions { floor: 1.5, ..o }).unwrap();
        assert_eq!(m.score_trace(&[1.0], &r), (2.0, 2));
        assert_eq!(m.score_trace(&[0.0], &r), (-1.0, 1));
        assert!(matches!(
            calibrate_trace(&runs, &TraceOptions { floor: 9.0, ..o }),
            Err(BoostError::NoData { positives: 0, .. })
        ));
        assert!(matches!(
            calibrate_trace(&runs, &TraceOptions { loss: 1.0, ..o }),
            Err(BoostError::BadOption {
                name: "trace loss",
                ..
            })
        ));
    }

    #[test]
    fn deterministic_for_any_thread_count_and_errors() {
        let (neg, pos) = toy(200, 2);
        let o = BoostOptions {
            n_weak: 8,
            seed: 5,
            tree: TreeOptions {
                frac_features: 0.5,
                ..TreeOptions::default()
            },
            ..BoostOptions::default()
        };
        let run = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| train_adaboost(&neg, &pos, &o, &mut |_| {}).unwrap())
        };
        assert_eq!(run(1), run(2));
        let real = train_adaboost(&neg, &pos, &BoostOptions { discrete: false, ..o }, &mut |_| {}).unwrap();
        assert_ne!(real, run(1));
        assert_eq!(
            train_adaboost(&neg, &[] as &[Vec<f32>], &o, &mut |_| {}),
            Err(BoostError::NoData {
                positives: 0,
                negatives: 200
            })
        );
        let short = vec![vec![0.0f32; 3]];
        assert!(matches!(
            train_adaboost(&neg, &short, &o, &mut |_| {}),
            Err(BoostError::FeatureCount {
                got: 3,
                expected: 20,
                ..
            })
        ));
        assert!(matches!(
            train_adaboost(&neg, &pos, &BoostOptions { n_weak: 0, ..o }, &mut |_| {}),
            Err(BoostError::BadOption { name: "n_weak", .. })
        ));
        let mut bad = run(1);
        bad.trees[0].fid[0] = 99;
        assert!(matches!(bad.validate(), Err(BoostError::BadTree { tree: 0, .. })));
    }
}
