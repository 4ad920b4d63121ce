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
        let trees: Vec<Tree2> = (0..300)
            .map(|_| Tree2 {
                off: std::array::from_fn(|_| rng.random_range(0..3000)),
                thr: std::array::from_fn(|_| rng.random_range(-0.5..0.5)),
                hs: std::array::from_fn(|_| rng.random_range(-0.6..0.5)),
            })
            .collect();
        for reject in [vec![f32::NEG_INFINITY; 300], vec![-1.0; 300], {
            (0..300).map(|k| -3.0 + k as f32 * 0.01).collect()
        }] {
            for (base0, n) in [(0usize, 37usize), (5, 64), (100, 3), (900, 0), (11, 1000)] {
                let mut want = (vec![0.0f32; n], vec![0u32; n]);
                score_run_scalar(&trees, &reject, &data, base0, &mut want.0, &mut want.1);
                let packed = PackedTrees::new(trees.clone());
                for isa in Isa::available() {
                    let mut got = (vec![0.0f32; n], vec![0u32; n]);
                    score_run(isa, &packed, &reject, &data, base0, &mut got.0, &mut got.1);
                    assert_eq!(got.1, want.1, "{isa} counts, run {base0}+{n}");
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&got.0), bits(&want.0), "{isa} scores, run {base0}+{n}");
                }
            }
        }
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
