//! Per-instruction-set kernels of the ACF detector's tree scoring: every intrinsic of
//! [`super`]'s scoring lives here, one file per ISA; the scalar code below is the oracle.
//!
//! A run of `n` windows at consecutive block columns of one level row is scored through depth-2
//! trees in the packed form [`Tree2`]. Because the windows of a run sit one block apart, the
//! feature a node reads is at consecutive addresses for consecutive windows: the SIMD paths read
//! one vector per node (no gathers), evaluate every tree for 8 (AVX2), 16 (AVX-512) or 4 (NEON)
//! windows at once, freeze a lane's running score when the soft cascade rejects it and stop when
//! every lane of the group is rejected. The running score of each window is the same sequence of
//! f32 additions as in the scalar oracle, so every path equals it **bit for bit** (scores and
//! trees evaluated). Windows left over after the last full group are scored by the scalar code.
//!
//! | kernel | scalar (oracle) | AVX2 | AVX-512 | NEON |
//! |---|---|---|---|---|
//! | tree scoring | one window at a time | 8 windows, `blendv` | 16 windows, mask registers | 4 windows, `bsl` |

use crate::kernels::Isa;

pub(crate) use scalar::{goes_right, score_run_scalar, Tree2};

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(target_arch = "aarch64")]
mod neon;
mod scalar;

/// Packed trees with the largest offset any node reads (computed once: the bound every
/// [`score_run`] checks).
pub(crate) struct PackedTrees {
    trees: Vec<Tree2>,
    max_off: usize,
}

impl PackedTrees {
    /// Pack `trees`.
    pub(crate) fn new(trees: Vec<Tree2>) -> Self {
        let max_off = trees.iter().flat_map(|t| t.off).max().unwrap_or(0) as usize;
        Self { trees, max_off }
    }
}

/// Score the `scores.len()` windows whose first values are at `data[base0 + i]`: `scores[i]` is
/// the running score when the window was rejected (the first tree `k` after which it is
/// `≤ reject[k]`) or after the last tree, `counts[i]` the trees evaluated.
///
/// # Panics
/// If a node reads outside `data` or the slices disagree in length.
pub(crate) fn score_run(
    isa: Isa,
    packed: &PackedTrees,
    reject: &[f32],
    data: &[f32],
    base0: usize,
    scores: &mut [f32],
    counts: &mut [u32],
) {
    let (trees, max_off) = (&packed.trees[..], packed.max_off);
    let n = scores.len();
    assert_eq!(counts.len(), n, "one count per score");
    assert_eq!(reject.len(), trees.len(), "one rejection threshold per tree");
    if n == 0 {
        return;
    }
    assert!(
        base0 + n - 1 + max_off < data.len(),
        "window run {base0}+{n} reads offset {max_off} beyond {} values",
        data.len()
    );
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the AVX2 path is chosen only when the CPU has AVX2 and FMA
        // (`Isa::is_available`); every read is below `data.len()` (asserted above).
        Isa::Avx2 => unsafe { avx2::score_run(trees, reject, data, base0, scores, counts) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, with AVX-512 F (checked by `Isa::is_available`).
        Isa::Avx512 => unsafe { avx512::score_run(trees, reject, data, base0, scores, counts) },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: as above; NEON is part of every aarch64 target.
        Isa::Neon => unsafe { neon::score_run(trees, reject, data, base0, scores, counts) },
        _ => score_run_scalar(trees, reject, data, base0, scores, counts),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Scores and counts of `n` windows at `base0` on every available path, each checked equal
    /// (bit for bit) to the scalar oracle; returns the oracle's.
    fn every_path_equals_the_oracle(
        trees: &[Tree2],
        reject: &[f32],
        data: &[f32],
        base0: usize,
        n: usize,
    ) -> (Vec<f32>, Vec<u32>) {
        let mut want = (vec![0.0f32; n], vec![0u32; n]);
        score_run_scalar(trees, reject, data, base0, &mut want.0, &mut want.1);
        let packed = PackedTrees::new(trees.to_vec());
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for isa in Isa::available() {
            // stale values in the outputs must not matter
            let mut got = (vec![f32::NAN; n], vec![u32::MAX; n]);
            score_run(isa, &packed, reject, data, base0, &mut got.0, &mut got.1);
            let what = format!("{isa}, run {base0}+{n}, {} trees", trees.len());
            assert_eq!(got.1, want.1, "{what}: counts");
            assert_eq!(bits(&got.0), bits(&want.0), "{what}: scores");
        }
        want
    }

    /// `n` random trees reading offsets below `max_off`.
    fn random_trees(rng: &mut impl Rng, n: usize, max_off: u32) -> Vec<Tree2> {
        (0..n)
            .map(|_| Tree2 {
                off: std::array::from_fn(|_| rng.random_range(0..max_off)),
                thr: std::array::from_fn(|_| rng.random_range(-0.5..0.5)),
                hs: std::array::from_fn(|_| rng.random_range(-0.6..0.5)),
            })
            .collect()
    }

    #[test]
    fn kernel_paths_equal_the_scalar_oracle() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let data: Vec<f32> = (0..4200)
            .map(|i| {
                if i % 97 == 0 {
                    f32::NAN // NaN goes right, as in the oracle
                } else {
                    rng.random_range(-1.0..1.0)
                }
            })
            .collect();
        let trees = random_trees(&mut rng, 300, 3000);
        for reject in [vec![f32::NEG_INFINITY; 300], vec![-1.0; 300], {
            (0..300).map(|k| -3.0 + k as f32 * 0.01).collect()
        }] {
            for t in [300, 17, 3, 0] {
                for (base0, n) in [(0usize, 37usize), (5, 64), (100, 3), (900, 0), (11, 1000)] {
                    every_path_equals_the_oracle(&trees[..t], &reject[..t], &data, base0, n);
                }
            }
        }
    }

    /// Trees that reject window `i` at tree `d_i = data[base0 + i]` exactly (never if
    /// `d_i ≥ T`): tree `t` adds `2⁻¹⁰·(t + 1)` while `t < d_i` and `−1000` at `t = d_i`, below
    /// every rejection threshold `−1`.
    fn death_trees(t: usize) -> (Vec<Tree2>, Vec<f32>) {
        let trees = (0..t)
            .map(|k| {
                let up = (k + 1) as f32 / 1024.0;
                Tree2 {
                    off: [0, 0, 0],
                    thr: [k as f32 + 0.5, 0.0, 0.0],
                    hs: [-1000.0, -1000.0, up, up],
                }
            })
            .collect();
        (trees, vec![-1.0; t])
    }

    #[test]
    fn lanes_rejected_at_different_trees() {
        // the lanes of one group rejected at different trees (the group runs on for the others:
        // a rejected lane's score and count stay frozen), runs shorter than a group and with a
        // tail after the last full group
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let t = 150;
        let (trees, reject) = death_trees(t);
        let special = [0usize, 1, 7, 8, 9, 15, 16, 17, 63, 64, 127, 149, 150, 400];
        for n in [1usize, 2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 33, 100, 465] {
            let death: Vec<usize> = (0..n)
                .map(|i| {
                    if rng.random_bool(0.5) {
                        special[i % special.len()]
                    } else {
                        rng.random_range(0..170)
                    }
                })
                .collect();
            let base0 = 3;
            let mut data = vec![0.0f32; base0 + n];
            for (x, &d) in data[base0..].iter_mut().zip(&death) {
                *x = d as f32;
            }
            let (scores, counts) = every_path_equals_the_oracle(&trees, &reject, &data, base0, n);
            let up = |k: usize| (0..k).map(|j| (j + 1) as f32 / 1024.0).sum::<f32>();
            for (i, &d) in death.iter().enumerate() {
                if d < t {
                    assert_eq!(counts[i], d as u32 + 1, "window {i} of {n}");
                    assert_eq!(scores[i], up(d) - 1000.0, "window {i} of {n}");
                } else {
                    assert_eq!(counts[i], t as u32, "window {i} of {n}");
                    assert_eq!(scores[i], up(t), "window {i} of {n}");
                }
            }
        }
    }

    #[test]
    fn every_window_rejected_or_none() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let t = 100;
        let (trees, reject) = death_trees(t);
        for n in [1usize, 3, 8, 16, 17, 40] {
            // all rejected by the first tree, all by one later tree, all within the first 8
            // trees at different ones, none
            for death in [0..1, 5..6, 0..8, t..t + 9] {
                let data: Vec<f32> = (0..n).map(|_| rng.random_range(death.clone()) as f32).collect();
                let (_, counts) = every_path_equals_the_oracle(&trees, &reject, &data, 0, n);
                for (&c, &d) in counts.iter().zip(&data) {
                    assert_eq!(c as usize, (d as usize + 1).min(t), "deaths {death:?}");
                }
            }
        }
        // random trees and no rejection threshold: every window through every tree
        let data: Vec<f32> = (0..500).map(|_| rng.random_range(-1.0..1.0)).collect();
        let trees = random_trees(&mut rng, 70, 200);
        let (_, counts) = every_path_equals_the_oracle(&trees, &[f32::NEG_INFINITY; 70], &data, 0, 300);
        assert!(counts.iter().all(|&c| c == 70));
    }

    #[test]
    #[should_panic(expected = "beyond")]
    fn reads_outside_the_data_are_refused() {
        let t = Tree2 {
            off: [0, 0, 10],
            ..Tree2::default()
        };
        score_run(
            Isa::Scalar,
            &PackedTrees::new(vec![t]),
            &[0.0],
            &[0.0; 10],
            0,
            &mut [0.0],
            &mut [0],
        );
    }
}
