//! Linear SVM training: L2-regularised hinge loss solved by dual coordinate descent (Hsieh et al.
//! 2008, liblinear's `L2R_L1LOSS_SVC_DUAL`), bias as an extra constant feature (regularised, as
//! liblinear with `-B 1`).
//!
//! ```
//! use mosaicd::detect::svm::{train_linear_svm, SvmOptions};
//! let x = vec![vec![2.0f32, 0.0], vec![0.0, 2.0], vec![-2.0, 0.0], vec![0.0, -2.0]];
//! let y = [1i8, 1, -1, -1];
//! let (w, b) = train_linear_svm(&x, &y, &SvmOptions { c: 10.0, ..Default::default() });
//! for (xi, yi) in x.iter().zip(y) {
//!     let s: f32 = xi.iter().zip(&w).map(|(a, b)| a * b).sum::<f32>() + b;
//!     assert!(s * yi as f32 > 0.0);
//! }
//! ```
//!
//! # Math
//! Dual: `min_α ½ αᵀQα − Σα` s.t. `0 ≤ α_i ≤ C`, `Q_ij = y_i y_j x̃_i·x̃_j` with `x̃ = [x, 1]`.
//! Coordinate step: `G = y_i w̃·x̃_i − 1`, projected gradient `PG`, `α_i ← clip(α_i − G/Q_ii, 0, C)`,
//! `w̃ += (α_i − α_old) y_i x̃_i`. Stops when `max PG − min PG < eps` over an epoch (liblinear's
//! criterion) or after `max_epochs`. Order shuffled each epoch with a seeded ChaCha generator, so
//! training is deterministic given the seed.

use rand::seq::SliceRandom;
use rand::SeedableRng;

/// SVM options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SvmOptions {
    /// Cost C (Dalal & Triggs used 0.01).
    pub c: f64,
    /// Stopping tolerance on the projected-gradient spread (liblinear default 0.1).
    pub eps: f64,
    /// Epoch limit.
    pub max_epochs: usize,
    /// Shuffle seed.
    pub seed: u64,
}

impl Default for SvmOptions {
    fn default() -> Self {
        Self {
            c: 0.01,
            eps: 0.1,
            max_epochs: 200,
            seed: 0,
        }
    }
}

/// Train; returns (weights, bias). Labels are +1 / −1. Empty input gives zero weights.
pub fn train_linear_svm(x: &[Vec<f32>], y: &[i8], o: &SvmOptions) -> (Vec<f32>, f32) {
    let n = x.len().min(y.len());
    let d = x.first().map_or(0, |v| v.len());
    let mut w = vec![0.0f64; d];
    let mut b = 0.0f64;
    let mut alpha = vec![0.0f64; n];
    let qii: Vec<f64> = x[..n]
        .iter()
        .map(|v| v.iter().map(|&a| a as f64 * a as f64).sum::<f64>() + 1.0)
        .collect();
    let mut order: Vec<usize> = (0..n).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(o.seed);
    for _ in 0..o.max_epochs {
        order.shuffle(&mut rng);
        let (mut pg_max, mut pg_min) = (f64::NEG_INFINITY, f64::INFINITY);
        for &i in &order {
            let yi = y[i] as f64;
            let xi = &x[i];
            let g = yi * (xi.iter().zip(&w).map(|(&a, &b)| a as f64 * b).sum::<f64>() + b) - 1.0;
            let pg = if alpha[i] == 0.0 {
                g.min(0.0)
            } else if alpha[i] >= o.c {
                g.max(0.0)
            } else {
                g
            };
            pg_max = pg_max.max(pg);
            pg_min = pg_min.min(pg);
            if pg.abs() > 1e-12 {
                let old = alpha[i];
                alpha[i] = (alpha[i] - g / qii[i]).clamp(0.0, o.c);
                let step = (alpha[i] - old) * yi;
                for (wk, &xk) in w.iter_mut().zip(xi) {
                    *wk += step * xk as f64;
                }
                b += step;
            }
        }
        if pg_max - pg_min < o.eps {
            break;
        }
    }
    (w.iter().map(|&v| v as f32).collect(), b as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separable_data_is_separated_and_deterministic() {
        let x: Vec<Vec<f32>> = (0..200)
            .map(|i| {
                let t = i as f32 * 0.7;
                let s = if i % 2 == 0 { 1.0 } else { -1.0 };
                vec![s * 1.0 + 0.3 * t.sin(), 0.5 * t.cos(), 0.2]
            })
            .collect();
        let y: Vec<i8> = (0..200).map(|i| if i % 2 == 0 { 1 } else { -1 }).collect();
        let o = SvmOptions {
            c: 1.0,
            seed: 3,
            ..Default::default()
        };
        let (w, b) = train_linear_svm(&x, &y, &o);
        let errors = x
            .iter()
            .zip(&y)
            .filter(|(xi, &yi)| (xi.iter().zip(&w).map(|(a, b)| a * b).sum::<f32>() + b) * yi as f32 <= 0.0)
            .count();
        assert_eq!(errors, 0);
        assert_eq!(train_linear_svm(&x, &y, &o), (w, b));
    }
}
