//! Percentile intervals of bootstrap draws.
//!
//! A bootstrap repeats a measurement on resamples (drawn with replacement) of the data and reads
//! its uncertainty off the spread of the draws. `Interval::of` is the 95 % percentile interval:
//! with the `n` draws sorted, `lo = v[round(0.025 (n - 1))]` and `hi = v[round(0.975 (n - 1))]`
//! (nearest rank, no interpolation).

/// A percentile interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Interval {
    /// 2.5th percentile.
    pub lo: f64,
    /// 97.5th percentile.
    pub hi: f64,
}

impl Interval {
    /// The 2.5–97.5 % percentile interval of `v` (not empty).
    pub(crate) fn of(mut v: Vec<f64>) -> Self {
        v.sort_by(f64::total_cmp);
        let q = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
        Self {
            lo: q(0.025),
            hi: q(0.975),
        }
    }
}
