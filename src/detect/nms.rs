//! Non-maximum suppression: greedy IoU suppression and OpenCV's `groupRectangles`.
//!
//! ```
//! use mosaicd::detect::{greedy_nms, Detection};
//! let d = |x: f32, s: f32| Detection { x, y: 0.0, width: 64.0, height: 128.0, score: s };
//! let kept = greedy_nms(&[d(0.0, 1.0), d(8.0, 2.0), d(300.0, 0.5)], 0.5);
//! assert_eq!(kept.len(), 2);
//! assert_eq!(kept[0].score, 2.0);
//! ```
//!
//! # Math
//! - **Greedy**: sort by score (descending), keep a box unless its intersection-over-union with a
//!   kept box exceeds `iou`.
//! - **groupRectangles** (OpenCV `cv::groupRectangles(rects, weights, groupThreshold, eps)`, what
//!   `detectMultiScale` calls with `finalThreshold` = 2, `eps` = 0.2): boxes are similar when all
//!   four edges differ by at most `δ = eps·(min(w₁,w₂) + min(h₁,h₂))/2`; classes are the transitive
//!   closure; a class with at most `group_threshold` members is dropped; the rest become the mean
//!   box (integer-truncated like OpenCV) with the class's maximum score; finally a class box lying
//!   inside another class box (tolerance `eps`·size) is dropped when the other class is larger
//!   (`n₂ > max(3, n₁)`) or its own class is small (`n₁ < 3`).

use super::Detection;

/// Intersection over union of two boxes.
pub fn iou(a: &Detection, b: &Detection) -> f32 {
    let x0 = a.x.max(b.x);
    let y0 = a.y.max(b.y);
    let x1 = (a.x + a.width).min(b.x + b.width);
    let y1 = (a.y + a.height).min(b.y + b.height);
    let inter = (x1 - x0).max(0.0) * (y1 - y0).max(0.0);
    let union = a.width * a.height + b.width * b.height - inter;
    if union > 0.0 {
        inter / union
    } else {
        0.0
    }
}

/// Greedy IoU suppression; output sorted by descending score (ties: input order).
pub fn greedy_nms(dets: &[Detection], iou_threshold: f32) -> Vec<Detection> {
    let mut order: Vec<usize> = (0..dets.len()).collect();
    order.sort_by(|&a, &b| dets[b].score.total_cmp(&dets[a].score).then(a.cmp(&b)));
    let mut kept: Vec<Detection> = Vec::new();
    for i in order {
        if kept.iter().all(|k| iou(k, &dets[i]) <= iou_threshold) {
            kept.push(dets[i]);
        }
    }
    kept
}

fn similar(a: &Detection, b: &Detection, eps: f32) -> bool {
    let delta = eps * (a.width.min(b.width) + a.height.min(b.height)) * 0.5;
    (a.x - b.x).abs() <= delta
        && (a.y - b.y).abs() <= delta
        && (a.x + a.width - b.x - b.width).abs() <= delta
        && (a.y + a.height - b.y - b.height).abs() <= delta
}

fn find(p: &mut [usize], mut i: usize) -> usize {
    while p[i] != i {
        p[i] = p[p[i]];
        i = p[i];
    }
    i
}

/// OpenCV `groupRectangles` with weights (see module docs). `group_threshold` 0 returns the input.
pub(crate) fn group_rectangles(dets: &[Detection], group_threshold: usize, eps: f32) -> Vec<Detection> {
    if group_threshold == 0 || dets.is_empty() {
        return dets.to_vec();
    }
    let n = dets.len();
    let mut parent: Vec<usize> = (0..n).collect();
    for i in 0..n {
        for j in 0..i {
            if similar(&dets[i], &dets[j], eps) {
                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
    }
    // Classes numbered in order of first appearance (as cv::partition does).
    let mut label = vec![usize::MAX; n];
    let mut classes: Vec<([f64; 4], usize, f32)> = Vec::new();
    for (i, d) in dets.iter().enumerate() {
        let r = find(&mut parent, i);
        if label[r] == usize::MAX {
            label[r] = classes.len();
            classes.push(([0.0; 4], 0, f32::NEG_INFINITY));
        }
        let c = &mut classes[label[r]];
        c.0[0] += d.x as f64;
        c.0[1] += d.y as f64;
        c.0[2] += d.width as f64;
        c.0[3] += d.height as f64;
        c.1 += 1;
        c.2 = c.2.max(d.score);
    }
    let boxes: Vec<(Detection, usize)> = classes
        .iter()
        .map(|(s, k, w)| {
            let f = 1.0 / *k as f64;
            // saturate_cast<int> rounds to nearest.
            let r = |v: f64| (v * f).round() as f32;
            (
                Detection {
                    x: r(s[0]),
                    y: r(s[1]),
                    width: r(s[2]),
                    height: r(s[3]),
                    score: *w,
                },
                *k,
            )
        })
        .collect();
    let mut out = Vec::new();
    for (i, (r1, n1)) in boxes.iter().enumerate() {
        if *n1 <= group_threshold {
            continue;
        }
        let inside = boxes.iter().enumerate().any(|(j, (r2, n2))| {
            if j == i || *n2 <= group_threshold {
                return false;
            }
            let dx = (r2.width * eps).round();
            let dy = (r2.height * eps).round();
            i != j
                && r1.x >= r2.x - dx
                && r1.y >= r2.y - dy
                && r1.x + r1.width <= r2.x + r2.width + dx
                && r1.y + r1.height <= r2.y + r2.height + dy
                && (*n2 > (*n1).max(3) || *n1 < 3)
        });
        if !inside {
            out.push(*r1);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(x: f32, y: f32, w: f32, s: f32) -> Detection {
        Detection {
            x,
            y,
            width: w,
            height: 2.0 * w,
            score: s,
        }
    }

    #[test]
    fn iou_by_hand() {
        let a = d(0.0, 0.0, 10.0, 1.0); // 10x20
        let b = d(5.0, 0.0, 10.0, 1.0);
        assert!((iou(&a, &b) - 100.0 / 300.0).abs() < 1e-6);
        assert_eq!(iou(&a, &d(100.0, 0.0, 10.0, 1.0)), 0.0);
    }

    #[test]
    fn greedy_keeps_best_of_overlaps() {
        let kept = greedy_nms(
            &[
                d(0.0, 0.0, 64.0, 0.3),
                d(4.0, 4.0, 64.0, 0.9),
                d(200.0, 0.0, 64.0, 0.1),
            ],
            0.5,
        );
        assert_eq!(kept.iter().map(|k| k.score).collect::<Vec<_>>(), vec![0.9, 0.1]);
    }

    #[test]
    fn grouping_needs_more_than_threshold_members() {
        // Three similar boxes → one mean box with max score; a lone box is dropped at threshold 2.
        let dets = [
            d(0.0, 0.0, 64.0, 0.5),
            d(4.0, 0.0, 64.0, 1.5),
            d(8.0, 4.0, 64.0, 0.2),
            d(400.0, 0.0, 64.0, 3.0),
        ];
        let g = group_rectangles(&dets, 2, 0.2);
        assert_eq!(g.len(), 1);
        assert_eq!((g[0].x, g[0].y, g[0].width, g[0].score), (4.0, 1.0, 64.0, 1.5));
        assert_eq!(group_rectangles(&dets, 0, 0.2).len(), 4);
    }
}
