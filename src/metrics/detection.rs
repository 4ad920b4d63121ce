//! Detection metrics: DET curves (miss rate vs FPPW / FPPI) and PASCAL average precision.
//!
//! ```
//! use mosaicd::metrics::{det_curve, miss_rate_at_fppw};
//! // Positive windows score high, negative windows low, one negative is a hard false positive.
//! let pos = [2.0, 1.5, 0.5, -0.2];
//! let neg = [0.7, -1.0, -1.2, -2.0];
//! let curve = det_curve(&pos, &neg).unwrap();
//! // At FPPW 0 the threshold sits above 0.7: two of four positives are still found.
//! assert_eq!(miss_rate_at_fppw(&curve, 0.0), 0.5);
//! // One false positive in four negatives lets every positive through.
//! assert_eq!(miss_rate_at_fppw(&curve, 0.25), 0.0);
//! ```
//!
//! ## Window-level DET (Dalal & Triggs 2005)
//! A classifier scores every positive window and every negative window. For a threshold `t`
//! (window accepted when `score ≥ t`): `miss rate = #{pos < t} / #pos`,
//! `FPPW = #{neg ≥ t} / #neg`. [`det_curve`] returns one point per distinct score, from the
//! strictest threshold to the loosest (FPPW rising, miss rate falling). Dalal & Triggs report the
//! miss rate at `FPPW = 1e-4`; [`miss_rate_at_fppw`] gives the lowest miss rate reached at or below a
//! target FPPW (a step read-out, no interpolation).
//!
//! ## Full-image detection (PASCAL VOC)
//! Detections of all images are sorted by score; each is matched to the not-yet-matched ground
//! truth box of its image with the highest `IoU ≥ 0.5` (true positive), otherwise it is a false
//! positive (this includes duplicates). Precision/recall follow; [`ApMethod::AllPoints`] is the VOC
//! 2010+ area under the monotone precision envelope, [`ApMethod::ElevenPoint`] the VOC 2007 11-point
//! average. [`mr_fppi_curve`] and [`log_average_miss_rate`] give the Caltech-style miss rate vs
//! false positives per image and its log-average over 9 FPPI points in [1e-2, 1] (Dollár et al.
//! 2012); a reference point not reached by the curve counts as miss rate 1 (conservative; Dollár's
//! code uses other fill-ins).
//!
//! ## References
//! N. Dalal, B. Triggs, "Histograms of Oriented Gradients for Human Detection", CVPR 2005.
//! M. Everingham et al., "The PASCAL Visual Object Classes (VOC) Challenge", IJCV 2010.
//! P. Dollár, C. Wojek, B. Schiele, P. Perona, "Pedestrian Detection: An Evaluation of the State of
//! the Art", PAMI 2012.

use super::{MetricsError, Result};
use crate::geometry::Detection;
/// Re-exported from [`crate::geometry`], where it lives.
pub(crate) use crate::geometry::Rect;
use serde::{Deserialize, Serialize};

/// PASCAL's overlap threshold for a true positive.
pub(crate) const PASCAL_IOU: f64 = 0.5;
/// Dalal & Triggs' reference false-positive-per-window rate.
pub const DALAL_FPPW: f64 = 1e-4;

/// One point of a window-level DET curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DetPoint {
    /// Acceptance threshold (`score ≥ threshold`).
    pub threshold: f64,
    /// False positives per window at this threshold.
    pub fppw: f64,
    /// Miss rate (fraction of positive windows rejected).
    pub miss_rate: f64,
}

fn finite_scores(what: &'static str, s: &[f32]) -> Result<()> {
    if s.is_empty() {
        return Err(MetricsError::NoSamples { what });
    }
    if let Some(&v) = s.iter().find(|v| !v.is_finite()) {
        return Err(MetricsError::InvalidParameter {
            name: what,
            value: f64::from(v),
            reason: "scores must be finite",
        });
    }
    Ok(())
}

/// Window-level DET curve from the scores of positive and negative windows, one point per distinct
/// score, strictest threshold first. The first point is the threshold just above every score
/// (`+∞`: FPPW 0, miss rate 1).
pub fn det_curve(pos_scores: &[f32], neg_scores: &[f32]) -> Result<Vec<DetPoint>> {
    finite_scores("pos_scores", pos_scores)?;
    finite_scores("neg_scores", neg_scores)?;
    // (score, is_positive), highest first.
    let mut all: Vec<(f32, bool)> = pos_scores
        .iter()
        .map(|&s| (s, true))
        .chain(neg_scores.iter().map(|&s| (s, false)))
        .collect();
    all.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (np, nn) = (pos_scores.len() as f64, neg_scores.len() as f64);
    let mut out = vec![DetPoint {
        threshold: f64::INFINITY,
        fppw: 0.0,
        miss_rate: 1.0,
    }];
    let (mut tp, mut fp) = (0usize, 0usize);
    let mut i = 0;
    while i < all.len() {
        let t = all[i].0;
        while i < all.len() && all[i].0 == t {
            if all[i].1 {
                tp += 1;
            } else {
                fp += 1;
            }
            i += 1;
        }
        out.push(DetPoint {
            threshold: f64::from(t),
            fppw: fp as f64 / nn,
            miss_rate: 1.0 - tp as f64 / np,
        });
    }
    Ok(out)
}

/// The lowest miss rate of `curve` at `FPPW ≤ target` (1 if no point qualifies).
pub fn miss_rate_at_fppw(curve: &[DetPoint], target: f64) -> f64 {
    curve
        .iter()
        .filter(|p| p.fppw <= target)
        .map(|p| p.miss_rate)
        .fold(1.0, f64::min)
}

/// Intersection over union of two boxes (0 when either is empty).
pub(crate) fn iou(a: &Rect, b: &Rect) -> f64 {
    let (ax0, ay0, ax1, ay1) = (
        a.x as f64,
        a.y as f64,
        (a.x + a.width) as f64,
        (a.y + a.height) as f64,
    );
    let (bx0, by0, bx1, by1) = (
        b.x as f64,
        b.y as f64,
        (b.x + b.width) as f64,
        (b.y + b.height) as f64,
    );
    let iw = (ax1.min(bx1) - ax0.max(bx0)).max(0.0);
    let ih = (ay1.min(by1) - ay0.max(by0)).max(0.0);
    let inter = iw * ih;
    let union =
        (ax1 - ax0).max(0.0) * (ay1 - ay0).max(0.0) + (bx1 - bx0).max(0.0) * (by1 - by0).max(0.0) - inter;
    if union <= 0.0 {
        0.0
    } else {
        inter / union
    }
}

/// How the area under the precision/recall curve is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum ApMethod {
    /// VOC 2010+: area under the monotone (non-increasing) precision envelope at every recall step.
    AllPoints,
    /// VOC 2007: mean of the envelope's precision at recall 0, 0.1, …, 1.
    ElevenPoint,
}

/// Detections and ground truth of one image.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ImageDetections {
    /// Detector output.
    pub detections: Vec<Detection>,
    /// Ground-truth boxes.
    pub ground_truth: Vec<Rect>,
}

/// A matched, score-sorted list of all detections of a data set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct MatchedDetections {
    /// `(score, true_positive)` for every detection, highest score first.
    pub ranked: Vec<(f32, bool)>,
    /// Number of ground-truth boxes.
    pub n_ground_truth: usize,
    /// Number of images.
    pub n_images: usize,
}

/// Greedy PASCAL matching of every image's detections (highest score first) to its ground truth.
pub(crate) fn match_detections(images: &[ImageDetections], iou_threshold: f64) -> Result<MatchedDetections> {
    if !(iou_threshold > 0.0 && iou_threshold <= 1.0) {
        return Err(MetricsError::InvalidParameter {
            name: "iou_threshold",
            value: iou_threshold,
            reason: "must be in (0, 1]",
        });
    }
    let mut ranked = Vec::new();
    let mut n_gt = 0;
    for img in images {
        n_gt += img.ground_truth.len();
        let mut order: Vec<&Detection> = img.detections.iter().collect();
        if let Some(d) = order.iter().find(|d| !d.score.is_finite()) {
            return Err(MetricsError::InvalidParameter {
                name: "detection score",
                value: f64::from(d.score),
                reason: "scores must be finite",
            });
        }
        order.sort_by(|a, b| b.score.total_cmp(&a.score));
        let mut used = vec![false; img.ground_truth.len()];
        for d in order {
            let r = Rect::from(d);
            let mut best = (iou_threshold, None);
            for (g, gt) in img.ground_truth.iter().enumerate() {
                let o = iou(&r, gt);
                if o >= best.0 && !used[g] && (best.1.is_none() || o > best.0) {
                    best = (o, Some(g));
                }
            }
            let tp = if let Some(g) = best.1 {
                used[g] = true;
                true
            } else {
                false
            };
            ranked.push((d.score, tp));
        }
    }
    ranked.sort_by(|a, b| b.0.total_cmp(&a.0));
    Ok(MatchedDetections {
        ranked,
        n_ground_truth: n_gt,
        n_images: images.len(),
    })
}

/// Average precision and its precision/recall curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ApResult {
    /// Average precision in [0, 1].
    pub ap: f64,
    /// Precision after each ranked detection.
    pub precision: Vec<f64>,
    /// Recall after each ranked detection.
    pub recall: Vec<f64>,
}

/// PASCAL average precision of matched detections. With no ground truth the AP is undefined: error.
pub(crate) fn average_precision(m: &MatchedDetections, method: ApMethod) -> Result<ApResult> {
    if m.n_ground_truth == 0 {
        return Err(MetricsError::NoSamples { what: "ground truth" });
    }
    let (mut tp, mut fp) = (0usize, 0usize);
    let mut precision = Vec::with_capacity(m.ranked.len());
    let mut recall = Vec::with_capacity(m.ranked.len());
    for &(_, is_tp) in &m.ranked {
        if is_tp {
            tp += 1
        } else {
            fp += 1
        }
        precision.push(tp as f64 / (tp + fp) as f64);
        recall.push(tp as f64 / m.n_ground_truth as f64);
    }
    // Monotone envelope: p_env[i] = max_{j ≥ i} p[j].
    let mut env = precision.clone();
    for i in (0..env.len().saturating_sub(1)).rev() {
        env[i] = env[i].max(env[i + 1]);
    }
    let ap = match method {
        ApMethod::AllPoints => {
            let mut ap = 0.0;
            let mut prev_r = 0.0;
            for (i, &r) in recall.iter().enumerate() {
                ap += (r - prev_r) * env[i];
                prev_r = r;
            }
            ap
        }
        ApMethod::ElevenPoint => {
            (0..=10)
                .map(|k| {
                    let t = k as f64 / 10.0;
                    recall
                        .iter()
                        .zip(&env)
                        .filter(|(r, _)| **r >= t - 1e-12)
                        .map(|(_, p)| *p)
                        .fold(0.0, f64::max)
                })
                .sum::<f64>()
                / 11.0
        }
    };
    Ok(ApResult {
        ap,
        precision,
        recall,
    })
}

/// Convenience: match with `PASCAL_IOU` (IoU 0.5) and compute the all-points AP.
pub fn pascal_ap(images: &[ImageDetections]) -> Result<ApResult> {
    average_precision(&match_detections(images, PASCAL_IOU)?, ApMethod::AllPoints)
}

/// One point of a miss rate vs false positives per image curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct FppiPoint {
    /// Score threshold.
    pub threshold: f64,
    /// False positives per image.
    pub fppi: f64,
    /// Miss rate (1 − recall).
    pub miss_rate: f64,
}

/// Miss rate vs FPPI from matched detections, strictest threshold first.
pub(crate) fn mr_fppi_curve(m: &MatchedDetections) -> Result<Vec<FppiPoint>> {
    if m.n_ground_truth == 0 {
        return Err(MetricsError::NoSamples { what: "ground truth" });
    }
    if m.n_images == 0 {
        return Err(MetricsError::NoSamples { what: "images" });
    }
    let mut out = vec![FppiPoint {
        threshold: f64::INFINITY,
        fppi: 0.0,
        miss_rate: 1.0,
    }];
    let (mut tp, mut fp) = (0usize, 0usize);
    let mut i = 0;
    while i < m.ranked.len() {
        let t = m.ranked[i].0;
        while i < m.ranked.len() && m.ranked[i].0 == t {
            if m.ranked[i].1 {
                tp += 1
            } else {
                fp += 1
            }
            i += 1;
        }
        out.push(FppiPoint {
            threshold: f64::from(t),
            fppi: fp as f64 / m.n_images as f64,
            miss_rate: 1.0 - tp as f64 / m.n_ground_truth as f64,
        });
    }
    Ok(out)
}

/// Log-average miss rate over the 9 FPPI points `10^(-2 … 0 step 0.25)`: the geometric mean of the
/// lowest miss rate at `FPPI ≤` each point (1 when the curve does not reach it).
pub(crate) fn log_average_miss_rate(curve: &[FppiPoint]) -> f64 {
    /// Floor avoiding log(0), as in Dollár's toolbox.
    const MR_FLOOR: f64 = 1e-10;
    let refs = (0..9).map(|k| 10f64.powf(-2.0 + 0.25 * k as f64));
    let logs: f64 = refs
        .map(|r| {
            let mr = curve
                .iter()
                .filter(|p| p.fppi <= r)
                .map(|p| p.miss_rate)
                .fold(1.0, f64::min);
            mr.max(MR_FLOOR).ln()
        })
        .sum();
    (logs / 9.0).exp()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A detection (test constructor; also used by `eval::detection`'s tests).
    pub(crate) fn det(x: f32, y: f32, w: f32, h: f32, score: f32) -> Detection {
        Detection {
            x,
            y,
            width: w,
            height: h,
            score,
        }
    }
    /// A box (test constructor).
    pub(crate) fn rect(x: f32, y: f32, w: f32, h: f32) -> Rect {
        Rect {
            x,
            y,
            width: w,
            height: h,
        }
    }

    #[test]
    fn det_curve_hand_computed() {
        let c = det_curve(&[3.0, 1.0], &[2.0, 0.0, -1.0, -1.0]).unwrap();
        let pts: Vec<(f64, f64)> = c.iter().map(|p| (p.fppw, p.miss_rate)).collect();
        assert_eq!(
            pts,
            vec![
                (0.0, 1.0),
                (0.0, 0.5),
                (0.25, 0.5),
                (0.25, 0.0),
                (0.5, 0.0),
                (1.0, 0.0)
            ]
        );
        assert_eq!(miss_rate_at_fppw(&c, 0.1), 0.5);
        assert_eq!(miss_rate_at_fppw(&c, 0.25), 0.0);
        // FPPW never decreases, miss rate never increases.
        assert!(c
            .windows(2)
            .all(|w| w[1].fppw >= w[0].fppw && w[1].miss_rate <= w[0].miss_rate));
    }

    #[test]
    fn det_curve_rejects_bad_scores() {
        assert!(matches!(
            det_curve(&[], &[1.0]),
            Err(MetricsError::NoSamples { what: "pos_scores" })
        ));
        assert!(matches!(
            det_curve(&[1.0], &[f32::NAN]),
            Err(MetricsError::InvalidParameter { .. })
        ));
    }

    #[test]
    fn iou_hand_computed() {
        let a = rect(0.0, 0.0, 2.0, 2.0);
        let b = rect(1.0, 0.0, 2.0, 2.0);
        assert!((iou(&a, &b) - 2.0 / 6.0).abs() < 1e-12);
        assert_eq!(iou(&a, &a), 1.0);
        assert_eq!(iou(&a, &rect(5.0, 5.0, 1.0, 1.0)), 0.0);
        assert_eq!(iou(&rect(0.0, 0.0, 0.0, 0.0), &rect(0.0, 0.0, 0.0, 0.0)), 0.0);
    }

    #[test]
    fn ap_perfect_and_hand_computed() {
        let perfect = vec![ImageDetections {
            detections: vec![det(0.0, 0.0, 10.0, 20.0, 1.0), det(50.0, 0.0, 10.0, 20.0, 0.5)],
            ground_truth: vec![rect(0.0, 0.0, 10.0, 20.0), rect(50.0, 0.0, 10.0, 20.0)],
        }];
        assert_eq!(pascal_ap(&perfect).unwrap().ap, 1.0);

        // Ranked: TP, FP (duplicate of the first box), TP; 3 ground truths (one never found).
        let imgs = vec![
            ImageDetections {
                detections: vec![det(0.0, 0.0, 10.0, 20.0, 0.9), det(1.0, 0.0, 10.0, 20.0, 0.8)],
                ground_truth: vec![rect(0.0, 0.0, 10.0, 20.0)],
            },
            ImageDetections {
                detections: vec![det(100.0, 100.0, 10.0, 20.0, 0.7)],
                ground_truth: vec![rect(100.0, 100.0, 10.0, 20.0), rect(0.0, 0.0, 5.0, 5.0)],
            },
        ];
        let m = match_detections(&imgs, PASCAL_IOU).unwrap();
        assert_eq!(m.ranked, vec![(0.9, true), (0.8, false), (0.7, true)]);
        let r = average_precision(&m, ApMethod::AllPoints).unwrap();
        // precision 1, 1/2, 2/3; recall 1/3, 1/3, 2/3; envelope 1, 2/3, 2/3.
        assert!((r.ap - (1.0 / 3.0 + (1.0 / 3.0) * (2.0 / 3.0))).abs() < 1e-12);
        let r11 = average_precision(&m, ApMethod::ElevenPoint).unwrap();
        // recall ≥ 0, .1, .2, .3 → 1 (r=1/3 reaches 0.333 ≥ .3); .4–.6 → 2/3; .7–1 → 0.
        assert!((r11.ap - (4.0 + 3.0 * 2.0 / 3.0) / 11.0).abs() < 1e-12);
    }

    #[test]
    fn each_ground_truth_matches_once_and_best_overlap_wins() {
        let imgs = vec![ImageDetections {
            detections: vec![det(2.0, 0.0, 10.0, 10.0, 0.9)],
            ground_truth: vec![rect(0.0, 0.0, 10.0, 10.0), rect(2.0, 0.0, 10.0, 10.0)],
        }];
        let m = match_detections(&imgs, PASCAL_IOU).unwrap();
        assert_eq!(m.ranked, vec![(0.9, true)]);
        let r = pascal_ap(&imgs).unwrap();
        assert!((r.ap - 0.5).abs() < 1e-12);
    }

    #[test]
    fn fppi_and_log_average() {
        let imgs = vec![ImageDetections {
            detections: vec![det(0.0, 0.0, 10.0, 10.0, 0.9), det(40.0, 0.0, 10.0, 10.0, 0.1)],
            ground_truth: vec![rect(0.0, 0.0, 10.0, 10.0), rect(80.0, 0.0, 10.0, 10.0)],
        }];
        let m = match_detections(&imgs, PASCAL_IOU).unwrap();
        let c = mr_fppi_curve(&m).unwrap();
        assert_eq!(c.len(), 3);
        assert_eq!((c[1].fppi, c[1].miss_rate), (0.0, 0.5));
        assert_eq!((c[2].fppi, c[2].miss_rate), (1.0, 0.5));
        assert!((log_average_miss_rate(&c) - 0.5).abs() < 1e-12);
        assert!(matches!(
            average_precision(
                &MatchedDetections {
                    ranked: vec![],
                    n_ground_truth: 0,
                    n_images: 1
                },
                ApMethod::AllPoints
            ),
            Err(MetricsError::NoSamples { .. })
        ));
    }
}
