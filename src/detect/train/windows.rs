//! Window-level evaluation (Dalal & Triggs's DET protocol) on a held-out split, and its paired
//! bootstrap over photos.
//!
//! Every positive window and every negative window of the held-out photos is scored by the model;
//! the miss rate at a false-positives-per-window rate is read off the DET curve
//! ([`crate::metrics::detection`]). [`window_bootstrap`] resamples the held-out photos (a crop and
//! its mirror stay together) to give 95 % percentile intervals ([`crate::metrics::interval`]).

use super::domain::{load_rgb, positive_descriptor, DomainImage, InputPipeline, NEG_SEED_OFFSET};
use super::error::TrainError;
use super::split::photo_prefix;
use super::split::Split;
use crate::detect::input::MosaicPrep;

use crate::detect::detector::{Detector, DetectorOptions};
use crate::detect::model::{Domain, LinearModel};
use crate::detect::score::ScorePrecision;
use crate::metrics::detection::{det_curve, DetPoint};
use crate::metrics::interval::Interval;
use crate::raw::levels::Gains;
use crate::raw::Cfa;

/// Most points kept of a DET curve in [`WindowEval::det`] (enough for a plot).
const DET_PLOT_POINTS: usize = 400;

/// Window-level result on the validation split.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WindowEval {
    /// Validation positives.
    pub positives: usize,
    /// Negative windows scored (all windows at all levels of the validation negatives).
    pub negative_windows: usize,
    /// (FPPW, miss rate) at FPPW 1e-2, 1e-3, 1e-4.
    pub miss_rate_at: Vec<(f64, f64)>,
    /// The DET curve (miss rate vs FPPW), thinned to at most a few hundred points for plotting;
    /// the first and last points and every point where the miss rate changes by a plot-visible
    /// step are kept.
    pub det: Vec<DetPoint>,
    /// The scores behind the numbers, kept for `window_bootstrap` (not serialized).
    #[serde(skip)]
    pub scores: WindowScores,
}

/// Per-window scores of one [`evaluate_windows_via`] run, enough to recompute the miss rate at
/// FPPW up to `BOOTSTRAP_MAX_FPPW` on any resample of the held-out photos and negative images.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WindowScores {
    /// Score of each held-out positive, in `Split::val_pos` order.
    pub positives: Vec<f32>,
    /// Photo of each positive (an index into the distinct [`photo_prefix`]es, in order of first
    /// appearance): the bootstrap draws photos, so a crop and its mirror stay together.
    pub positive_photo: Vec<u32>,
    /// Windows scored in each negative image, in `Split::val_neg` order.
    pub windows_per_image: Vec<usize>,
    /// The highest negative scores, descending (ties by image index), each with its image index;
    /// all scores down to the one at rank `2 · BOOTSTRAP_MAX_FPPW · windows + 64`, and every score
    /// tied with that one.
    pub top_negatives: Vec<(f32, u32)>,
}

/// Highest FPPW [`window_bootstrap`] can evaluate.
pub(crate) const BOOTSTRAP_MAX_FPPW: f64 = 1e-2;

/// Thin a DET curve to at most about `max_points` points: the positive-FPPW range is cut into
/// `max_points` equal steps in log FPPW and the last point of each step (lowest miss rate there) is
/// kept, after the last point with FPPW 0.
pub(crate) fn thin_det_curve(curve: &[DetPoint], max_points: usize) -> Vec<DetPoint> {
    let mut out: Vec<DetPoint> = curve
        .iter()
        .rfind(|p| p.fppw == 0.0)
        .copied()
        .into_iter()
        .collect();
    let positive: Vec<&DetPoint> = curve.iter().filter(|p| p.fppw > 0.0).collect();
    let (Some(first), Some(last)) = (positive.first(), positive.last()) else {
        return out;
    };
    let lo = first.fppw.log10();
    let step = ((last.fppw.log10() - lo) / max_points.max(1) as f64).max(f64::MIN_POSITIVE);
    let mut last_bucket = None;
    for p in positive {
        let b = ((p.fppw.log10() - lo) / step).floor() as i64;
        match out.last_mut() {
            Some(q) if last_bucket == Some(b) => *q = *p,
            _ => out.push(*p),
        }
        last_bucket = Some(b);
    }
    out
}

/// Miss rate at a given FPPW from positive and negative scores: the threshold lets through
/// `floor(fppw · N)` negatives (ties counted as false positives).
pub(crate) fn miss_rate_at_fppw(pos: &[f32], neg_sorted_desc: &[f32], fppw: f64) -> f64 {
    if pos.is_empty() {
        return f64::NAN;
    }
    let k = (fppw * neg_sorted_desc.len() as f64).floor() as usize;
    // Threshold strictly above the (k+1)-th highest negative.
    let thr = neg_sorted_desc.get(k).copied().unwrap_or(f32::NEG_INFINITY);
    pos.iter().filter(|&&s| s <= thr).count() as f64 / pos.len() as f64
}

/// Evaluate a model on validation images in `domain` (Dalal–Triggs window protocol), the images
/// brought into `domain` through `pipeline` (as in training, or e.g. the reverse ISP with one of
/// the paper's noise levels). Positives and negatives are scored with `svm`'s arithmetic. Mosaics
/// made through the reverse ISP are in the model's tone with white-balance gains from `wb`
/// ([`Gains::FromFile`]: the profile's, the true white balance).
#[allow(clippy::too_many_arguments)]
pub fn evaluate_windows_via(
    model: &LinearModel,
    split: &Split,
    domain: Domain,
    cfa: Cfa,
    pipeline: &InputPipeline,
    svm: ScorePrecision,
    wb: Gains,
    progress: &mut dyn FnMut(&str),
) -> Result<WindowEval, TrainError> {
    let prep = MosaicPrep::for_model(model, wb);
    let opts = DetectorOptions {
        svm,
        ..DetectorOptions::default()
    };
    let det = Detector::new(model.clone(), &opts)?;
    let spec = det.hog_spec().clone();
    let mut pos = Vec::new();
    for (i, p) in split.val_pos.iter().enumerate() {
        let img = DomainImage::from_rgb_via(&load_rgb(p)?, domain, cfa, pipeline, i as u64, &prep)?;
        pos.push(det.score_descriptor(&positive_descriptor(&spec, &img)?));
    }
    let mut neg = Vec::new();
    let mut windows_per_image = Vec::with_capacity(split.val_neg.len());
    for (i, p) in split.val_neg.iter().enumerate() {
        let img = held_out_negative(p, i, domain, cfa, pipeline, &prep)?;
        let before = neg.len();
        det.for_each_window(&img.input(), |_, _, _, _, s| neg.push(s))?;
        windows_per_image.push(neg.len() - before);
        if i % 10 == 0 {
            progress(&format!(
                "eval: negatives {}/{} ({} windows)",
                i + 1,
                split.val_neg.len(),
                neg.len()
            ));
        }
    }
    window_eval(pos, photo_indices(&split.val_pos), &neg, windows_per_image)
}

/// Held-out negative image `i` (file `path`) in `domain` through `pipeline`, on its own noise
/// stream.
pub(super) fn held_out_negative(
    path: &std::path::Path,
    i: usize,
    domain: Domain,
    cfa: Cfa,
    pipeline: &InputPipeline,
    prep: &MosaicPrep,
) -> Result<DomainImage, TrainError> {
    DomainImage::from_rgb_via(
        &load_rgb(path)?,
        domain,
        cfa,
        pipeline,
        NEG_SEED_OFFSET + i as u64,
        prep,
    )
}

/// The photo of each positive: an index into the distinct [`photo_prefix`]es of `paths`, in
/// order of first appearance.
pub(super) fn photo_indices(paths: &[std::path::PathBuf]) -> Vec<u32> {
    let mut photos: Vec<&str> = Vec::new();
    paths
        .iter()
        .map(|p| {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            let photo = photo_prefix(name);
            let k = photos.iter().position(|&q| q == photo).unwrap_or_else(|| {
                photos.push(photo);
                photos.len() - 1
            });
            k as u32
        })
        .collect()
}

/// The window evaluation of positive scores `pos` (photos `positive_photo`) and negative scores
/// `neg`, `windows_per_image[i]` of them from negative image `i`, in turn.
pub(super) fn window_eval(
    pos: Vec<f32>,
    positive_photo: Vec<u32>,
    neg: &[f32],
    windows_per_image: Vec<usize>,
) -> Result<WindowEval, TrainError> {
    let (neg, top_negatives) = rank_negatives(neg, &windows_per_image);
    let miss_rate_at = [1e-2, 1e-3, 1e-4]
        .iter()
        .map(|&f| (f, miss_rate_at_fppw(&pos, &neg, f)))
        .collect();
    let det = thin_det_curve(&det_curve(&pos, &neg)?, DET_PLOT_POINTS);
    Ok(WindowEval {
        positives: pos.len(),
        negative_windows: neg.len(),
        miss_rate_at,
        det,
        scores: WindowScores {
            positives: pos,
            positive_photo,
            windows_per_image,
            top_negatives,
        },
    })
}

/// Every negative score, descending, and the top ones with their image index (see
/// [`WindowScores::top_negatives`]), from one sort; `neg` holds each image's windows in turn,
/// `windows_per_image[i]` of image `i`.
pub(super) fn rank_negatives(neg: &[f32], windows_per_image: &[usize]) -> (Vec<f32>, Vec<(f32, u32)>) {
    let mut all: Vec<(f32, u32)> = Vec::with_capacity(neg.len());
    let mut start = 0;
    for (i, &n) in windows_per_image.iter().enumerate() {
        all.extend(neg[start..start + n].iter().map(|&s| (s, i as u32)));
        start += n;
    }
    all.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let sorted = all.iter().map(|x| x.0).collect();
    let keep = (2.0 * BOOTSTRAP_MAX_FPPW * neg.len() as f64).ceil() as usize + 64;
    if keep < all.len() {
        let last = all[keep - 1].0;
        let end = keep + all[keep..].iter().take_while(|x| x.0 == last).count();
        all.truncate(end);
    }
    (sorted, all)
}

impl WindowScores {
    /// Number of held-out photos (what the bootstrap resamples on the positive side).
    pub fn photos(&self) -> usize {
        self.positive_photo.iter().max().map_or(0, |&m| m as usize + 1)
    }

    /// Miss rate at `fppw` with photo `p` counted `photo_w[p]` times and negative image `i`
    /// counted `image_w[i]` times, as `miss_rate_at_fppw` computes it on that multiset (with
    /// every weight 1, equal to it). An error if the threshold lies below the kept scores.
    pub fn weighted_miss_rate(&self, photo_w: &[u32], image_w: &[u32], fppw: f64) -> Result<f64, TrainError> {
        let windows: u64 = self
            .windows_per_image
            .iter()
            .zip(image_w)
            .map(|(&n, &w)| n as u64 * w as u64)
            .sum();
        let k = (fppw * windows as f64).floor() as u64;
        // The (k + 1)-th highest drawn negative: walk down the kept scores, each counted as often
        // as its image was drawn.
        let mut seen = 0u64;
        let mut thr = None;
        for &(s, i) in &self.top_negatives {
            seen += image_w[i as usize] as u64;
            if seen > k {
                thr = Some(s);
                break;
            }
        }
        let thr = match thr {
            Some(t) => t,
            None if self.top_negatives.len() == self.windows_per_image.iter().sum::<usize>() => {
                f32::NEG_INFINITY
            }
            None => {
                return Err(TrainError::BadOption {
                    what: "window bootstrap",
                    value: format!("FPPW {fppw} on a draw of {windows} windows"),
                    allowed: "a draw within the kept negative scores",
                })
            }
        };
        let (mut missed, mut total) = (0u64, 0u64);
        for (&s, &p) in self.positives.iter().zip(&self.positive_photo) {
            let w = photo_w[p as usize] as u64;
            total += w;
            if s <= thr {
                missed += w;
            }
        }
        Ok(if total == 0 {
            f64::NAN
        } else {
            missed as f64 / total as f64
        })
    }
}

/// One row of [`window_bootstrap`]: 95 % intervals (2.5–97.5 % percentiles of the draws).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub(crate) struct WindowBootstrapRow {
    /// Per FPPW of the call: the interval of the miss rate.
    pub miss_rate: Vec<Interval>,
    /// Per FPPW: the interval of the miss rate minus the reference row's on the same draw.
    pub diff: Vec<Interval>,
    /// Per FPPW: the share of draws in which this row misses no more than the reference row.
    pub not_worse: Vec<f64>,
}

/// Paired bootstrap of the window protocol: every draw (seeded `ChaCha8`, reproducible) takes the
/// held-out *photos* (a crop and its mirror together) and the negative *images* with replacement,
/// the same draw for every row, and recomputes each row's miss rate at each `fppw` as
/// [`miss_rate_at_fppw`] does on the drawn multiset: the threshold is the `(floor(fppw · N) + 1)`-th
/// highest negative score, `N` the drawn images' window count. The rows must come from the same
/// split (any models, domains or pipelines); `reference` indexes `rows`.
pub(crate) fn window_bootstrap(
    rows: &[&WindowScores],
    reference: usize,
    fppw: &[f64],
    resamples: usize,
    seed: u64,
) -> Result<Vec<WindowBootstrapRow>, TrainError> {
    let bad = |value: String, allowed: &'static str| TrainError::BadOption {
        what: "window bootstrap",
        value,
        allowed,
    };
    let first = rows.get(reference).ok_or_else(|| {
        bad(
            format!("reference row {reference} of {} rows", rows.len()),
            "a row of the table",
        )
    })?;
    if resamples == 0 || first.positives.is_empty() || first.windows_per_image.is_empty() {
        return Err(bad(
            format!(
                "{resamples} resamples, {} positives, {} negative images",
                first.positives.len(),
                first.windows_per_image.len()
            ),
            "at least one resample, positive and negative image",
        ));
    }
    if rows.iter().any(|r| {
        r.positive_photo != first.positive_photo || r.windows_per_image.len() != first.windows_per_image.len()
    }) {
        return Err(bad(
            "rows over different held-out files".into(),
            "rows of the same split",
        ));
    }
    if let Some(f) = fppw.iter().find(|f| !(0.0..=BOOTSTRAP_MAX_FPPW).contains(*f)) {
        return Err(bad(f.to_string(), "FPPW in 0 ..= 1e-2"));
    }
    use rand::{Rng, SeedableRng};
    let photos = first.photos();
    let images = first.windows_per_image.len();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut photo_w = vec![0u32; photos];
    let mut image_w = vec![0u32; images];
    // draws[row][f] = miss rates over the resamples.
    let mut draws = vec![vec![Vec::with_capacity(resamples); fppw.len()]; rows.len()];
    for _ in 0..resamples {
        photo_w.iter_mut().for_each(|w| *w = 0);
        image_w.iter_mut().for_each(|w| *w = 0);
        for _ in 0..photos {
            photo_w[rng.random_range(0..photos)] += 1;
        }
        for _ in 0..images {
            image_w[rng.random_range(0..images)] += 1;
        }
        for (r, row) in rows.iter().enumerate() {
            for (j, &f) in fppw.iter().enumerate() {
                draws[r][j].push(row.weighted_miss_rate(&photo_w, &image_w, f)?);
            }
        }
    }
    Ok(draws
        .iter()
        .map(|d| WindowBootstrapRow {
            miss_rate: d.iter().map(|v| Interval::of(v.clone())).collect(),
            diff: d
                .iter()
                .zip(&draws[reference])
                .map(|(v, w)| Interval::of(v.iter().zip(w).map(|(x, y)| x - y).collect()))
                .collect(),
            not_worse: d
                .iter()
                .zip(&draws[reference])
                .map(|(v, w)| v.iter().zip(w).filter(|(x, y)| x <= y).count() as f64 / resamples as f64)
                .collect(),
        })
        .collect())
}
