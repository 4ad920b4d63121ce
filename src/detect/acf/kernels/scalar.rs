//! The scalar oracle of the tree-scoring kernels and the packed tree they read: below the
//! dispatch in `mod.rs` and the per-ISA files, which all use it.

/// A depth-2 tree in the scoring form: nodes 0 (root), 1 (left child) and 2 (right child), each
/// reading the feature at offset `off[k]` from the window's first value and going right when
/// `!(x < thr[k])` (as [`crate::detect::boost::Tree::apply`]); leaf `2·b₀ + b₁` adds `hs[…]`.
/// Shallower trees are completed by repeating a leaf's value under a dummy split.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub(crate) struct Tree2 {
    /// Offsets of the features the three nodes read.
    pub off: [u32; 3],
    /// Thresholds of the three nodes.
    pub thr: [f32; 3],
    /// The four leaf values.
    pub hs: [f32; 4],
}

/// Whether a node sends feature value `x` right: `!(x < thr)`, as
/// [`crate::detect::boost::Tree::apply`] (a NaN goes right).
#[inline]
pub(crate) fn goes_right(x: f32, thr: f32) -> bool {
    x.partial_cmp(&thr) != Some(std::cmp::Ordering::Less)
}

/// The scalar oracle of [`score_run`] (also the SIMD paths' tail).
pub(crate) fn score_run_scalar(
    trees: &[Tree2],
    reject: &[f32],
    data: &[f32],
    base0: usize,
    scores: &mut [f32],
    counts: &mut [u32],
) {
    for (i, (s, c)) in scores.iter_mut().zip(counts.iter_mut()).enumerate() {
        let x = &data[base0 + i..];
        let mut h = 0.0f32;
        let mut n = 0u32;
        for (t, &r) in trees.iter().zip(reject) {
            let b0 = goes_right(x[t.off[0] as usize], t.thr[0]) as usize;
            let k = 1 + b0;
            let b1 = goes_right(x[t.off[k] as usize], t.thr[k]) as usize;
            h += t.hs[2 * b0 + b1];
            n += 1;
            if h <= r {
                break;
            }
        }
        *s = h;
        *c = n;
    }
}
