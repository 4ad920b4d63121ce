//! Descriptor matching and geometry: nearest neighbour with Lowe's ratio test and a mutual
//! check, the paper's least-squares transform `H^ = A^+ B`, and a seeded RANSAC estimate.
//!
//! ```
//! use mosaicd::features::sift::matching::{apply, least_squares_transform};
//! let a = [(0.0, 0.0), (10.0, 0.0), (0.0, 10.0), (10.0, 10.0)];
//! let b: Vec<(f64, f64)> = a.iter().map(|&(x, y)| (2.0 * x + 1.0, y - 3.0)).collect();
//! let h = least_squares_transform(&a, &b).unwrap();
//! let (x, y) = apply(&h, (5.0, 5.0));
//! assert!((x - 11.0).abs() < 1e-9 && (y - 2.0).abs() < 1e-9);
//! ```
//!
//! The transform is estimated as in the paper: rows `[x y 1]` of matched points in `A` and
//! `[x' y' 1]` in `B`, `H^ = A^+ B = (A^T A)^-1 A^T B`, which is an affine map (its last column
//! is `[0 0 1]^T`); points map as row vectors, `[x' y' 1] = [x y 1] H^`. RANSAC draws 3-point
//! samples from a `ChaCha8` generator seeded by the caller, counts inliers within `threshold`
//! pixels and refits `A^+ B` on the best inlier set, so the result is reproducible.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::DESCRIPTOR_LEN;

/// Lowe's ratio: the best match must be closer than this fraction of the second best.
pub const LOWE_RATIO: f32 = 0.8;

/// One correspondence between descriptor sets `a` (query) and `b` (train).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// Index in `a`.
    pub query: usize,
    /// Index in `b`.
    pub train: usize,
    /// Euclidean descriptor distance.
    pub distance: f32,
}

fn dist2(a: &[u8; DESCRIPTOR_LEN], b: &[u8; DESCRIPTOR_LEN]) -> u32 {
    a.iter()
        .zip(b)
        .map(|(&p, &q)| {
            let d = p as i32 - q as i32;
            (d * d) as u32
        })
        .sum()
}

/// For each descriptor of `a`: (best index in `b`, best d^2, second-best d^2).
fn nearest_two(a: &[[u8; DESCRIPTOR_LEN]], b: &[[u8; DESCRIPTOR_LEN]]) -> Vec<(usize, u32, u32)> {
    a.par_iter()
        .map(|da| {
            let (mut bi, mut b1, mut b2) = (usize::MAX, u32::MAX, u32::MAX);
            for (j, db) in b.iter().enumerate() {
                let d = dist2(da, db);
                if d < b1 {
                    b2 = b1;
                    b1 = d;
                    bi = j;
                } else if d < b2 {
                    b2 = d;
                }
            }
            (bi, b1, b2)
        })
        .collect()
}

/// Nearest-neighbour matches from `a` to `b` passing the ratio test (`d1 < ratio * d2`), and,
/// when `mutual`, whose `b` descriptor's nearest neighbour in `a` is the query. Ordered by query.
pub fn match_descriptors(
    a: &[[u8; DESCRIPTOR_LEN]],
    b: &[[u8; DESCRIPTOR_LEN]],
    ratio: f32,
    mutual: bool,
) -> Vec<Match> {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let ab = nearest_two(a, b);
    let ba = if mutual { Some(nearest_two(b, a)) } else { None };
    let r2 = (ratio as f64) * (ratio as f64);
    ab.iter()
        .enumerate()
        .filter_map(|(i, &(j, d1, d2))| {
            if j == usize::MAX {
                return None;
            }
            let passes = d2 == u32::MAX || (d1 as f64) < r2 * d2 as f64;
            let mutual_ok = ba.as_ref().is_none_or(|ba| ba[j].0 == i);
            (passes && mutual_ok).then(|| Match {
                query: i,
                train: j,
                distance: (d1 as f32).sqrt(),
            })
        })
        .collect()
}

/// A 3x3 transform applied to row vectors: `[x' y' w] = [x y 1] H`.
pub type Transform = [[f64; 3]; 3];

/// Map a point by `h` (row-vector convention, divided by the homogeneous coordinate).
pub fn apply(h: &Transform, (x, y): (f64, f64)) -> (f64, f64) {
    let u = x * h[0][0] + y * h[1][0] + h[2][0];
    let v = x * h[0][1] + y * h[1][1] + h[2][1];
    let w = x * h[0][2] + y * h[1][2] + h[2][2];
    (u / w, v / w)
}

fn solve3(m: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if !det.is_finite() || det.abs() < 1e-12 {
        return None;
    }
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let mut mk = m;
        for r in 0..3 {
            mk[r][k] = b[r];
        }
        let dk = mk[0][0] * (mk[1][1] * mk[2][2] - mk[1][2] * mk[2][1])
            - mk[0][1] * (mk[1][0] * mk[2][2] - mk[1][2] * mk[2][0])
            + mk[0][2] * (mk[1][0] * mk[2][1] - mk[1][1] * mk[2][0]);
        *o = dk / det;
    }
    Some(out)
}

/// The paper's `H^ = A^+ B` from point pairs (at least 3, not collinear); `None` when degenerate.
pub fn least_squares_transform(src: &[(f64, f64)], dst: &[(f64, f64)]) -> Option<Transform> {
    if src.len() != dst.len() || src.len() < 3 {
        return None;
    }
    // Normal equations (A^T A) X = A^T B, solved column by column (B's third column gives [0,0,1]).
    let mut ata = [[0.0f64; 3]; 3];
    let mut atbx = [0.0f64; 3];
    let mut atby = [0.0f64; 3];
    for (&(x, y), &(u, v)) in src.iter().zip(dst) {
        let a = [x, y, 1.0];
        for r in 0..3 {
            for c in 0..3 {
                ata[r][c] += a[r] * a[c];
            }
            atbx[r] += a[r] * u;
            atby[r] += a[r] * v;
        }
    }
    let cx = solve3(ata, atbx)?;
    let cy = solve3(ata, atby)?;
    Some([[cx[0], cy[0], 0.0], [cx[1], cy[1], 0.0], [cx[2], cy[2], 1.0]])
}

/// Result of [`ransac_transform`].
#[derive(Debug, Clone, PartialEq)]
pub struct RansacResult {
    /// The least-squares refit on the inliers.
    pub transform: Transform,
    /// Indices of the inlier pairs.
    pub inliers: Vec<usize>,
}

/// RANSAC over 3-point samples with `iterations` draws from `ChaCha8Rng::seed_from_u64(seed)`;
/// inliers are pairs whose mapped point is within `threshold` pixels. `None` when fewer than 3
/// pairs or no non-degenerate sample was found.
pub fn ransac_transform(
    src: &[(f64, f64)],
    dst: &[(f64, f64)],
    threshold: f64,
    iterations: usize,
    seed: u64,
) -> Option<RansacResult> {
    let n = src.len();
    if n < 3 || dst.len() != n {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let inliers_of = |h: &Transform| -> Vec<usize> {
        (0..n)
            .filter(|&i| {
                let (u, v) = apply(h, src[i]);
                let (du, dv) = (u - dst[i].0, v - dst[i].1);
                (du * du + dv * dv).sqrt() <= threshold
            })
            .collect()
    };
    let mut best: Option<Vec<usize>> = None;
    for _ in 0..iterations {
        let i = rng.random_range(0..n);
        let j = rng.random_range(0..n);
        let k = rng.random_range(0..n);
        if i == j || j == k || i == k {
            continue;
        }
        let s = [src[i], src[j], src[k]];
        let d = [dst[i], dst[j], dst[k]];
        let Some(h) = least_squares_transform(&s, &d) else {
            continue;
        };
        let inl = inliers_of(&h);
        if best.as_ref().is_none_or(|b| inl.len() > b.len()) {
            best = Some(inl);
        }
    }
    let best = best?;
    let s: Vec<_> = best.iter().map(|&i| src[i]).collect();
    let d: Vec<_> = best.iter().map(|&i| dst[i]).collect();
    let h = least_squares_transform(&s, &d)?;
    let inliers = inliers_of(&h);
    Some(RansacResult {
        transform: h,
        inliers,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_and_mutual_by_hand() {
        let mut a = [[0u8; DESCRIPTOR_LEN]; 2];
        let mut b = [[0u8; DESCRIPTOR_LEN]; 3];
        a[0][0] = 100;
        a[1][1] = 100;
        b[0][0] = 98; // close to a[0]
        b[1][1] = 60; // ambiguous for a[1]: b[1] at 40, b[2] at 42
        b[2][1] = 142;
        let m = match_descriptors(&a, &b, LOWE_RATIO, true);
        assert_eq!(m.len(), 1);
        assert_eq!((m[0].query, m[0].train), (0, 0));
        assert!((m[0].distance - 2.0).abs() < 1e-6);
    }

    #[test]
    fn ransac_recovers_a_rotation_with_outliers() {
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let h: Transform = [[c, s, 0.0], [-s, c, 0.0], [5.0, -7.0, 1.0]];
        let mut src = Vec::new();
        let mut dst = Vec::new();
        for i in 0..40 {
            let p = ((i * 37 % 101) as f64, (i * 53 % 89) as f64);
            src.push(p);
            dst.push(if i % 4 == 0 {
                (p.1, p.0 + 50.0)
            } else {
                apply(&h, p)
            });
        }
        let r = ransac_transform(&src, &dst, 1.0, 200, 7).unwrap();
        assert_eq!(r.inliers.len(), 30);
        for (a, b) in r.transform.iter().flatten().zip(h.iter().flatten()) {
            assert!((a - b).abs() < 1e-6);
        }
        assert_eq!(r, ransac_transform(&src, &dst, 1.0, 200, 7).unwrap());
    }
}
