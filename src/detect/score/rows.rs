//! [`RowScorer`]: window scores of a grid whose block rows arrive one at a time (one [`Stream`](super::strips::Stream), no grid).

use super::products::{f32_kernel, I8Kernel};
use super::strips::{F32Rows, I8Rows, RowProducts, Stream, StreamBuffers};
use super::weights::{ScoreWeights, ScoreWeightsI8};
use crate::kernels::Isa;

/// Window scores of a block grid whose rows arrive one at a time, top to bottom (for example
/// from [`crate::features::hog::approx_block_rows`], which makes no grid): the same scores, bit
/// for bit, as [`window_scores`](super::window_scores) / [`window_scores_i8`](super::window_scores_i8) of the whole grid, on one thread.
pub(crate) struct RowScorer<'w> {
    kind: RowScorerKind<'w>,
    nby: usize,
    pushed: usize,
}

pub(super) enum RowScorerKind<'w> {
    /// Fewer blocks than a window: no scores.
    Empty,
    F32(Stream<F32Rows<'w>>),
    I8(Stream<I8Rows<'w>>),
}

/// The allocations of a [`RowScorer`] ([`RowScorer::into_buffers`]) for the next one: a caller
/// that scores many levels and frames keeps them instead of allocating (and zeroing) products
/// and window sums for each.
#[derive(Debug, Default)]
pub(crate) struct ScorerBuffers {
    f32: StreamBuffers<F32Rows<'static>>,
    i8: StreamBuffers<I8Rows<'static>>,
}

impl<'w> RowScorer<'w> {
    /// The f32 scores of an `nbx x nby`-block grid on kernel path `isa` ([`window_scores_with`](super::strips::window_scores_with)).
    #[cfg(test)]
    pub(crate) fn f32(w: &'w ScoreWeights, isa: Isa, nbx: usize, nby: usize) -> Self {
        Self::f32_in(w, isa, nbx, nby, ScorerBuffers::default())
    }

    /// [`RowScorer::f32`] in the allocations of `b`.
    pub(crate) fn f32_in(w: &'w ScoreWeights, isa: Isa, nbx: usize, nby: usize, b: ScorerBuffers) -> Self {
        let r = F32Rows {
            w,
            kernel: f32_kernel(isa),
        };
        Self::with(r, nbx, nby, b.f32, RowScorerKind::F32)
    }

    /// The 8-bit scores of an `nbx x nby`-block grid on kernel path `isa`
    /// ([`window_scores_i8_with`](super::strips::window_scores_i8_with)).
    #[cfg(test)]
    pub(crate) fn i8(w: &'w ScoreWeightsI8, isa: Isa, nbx: usize, nby: usize) -> Self {
        Self::i8_in(w, isa, nbx, nby, ScorerBuffers::default())
    }

    /// [`RowScorer::i8`] in the allocations of `b`.
    pub(crate) fn i8_in(w: &'w ScoreWeightsI8, isa: Isa, nbx: usize, nby: usize, b: ScorerBuffers) -> Self {
        let kernel = I8Kernel::for_isa(isa).or_scalar();
        Self::with(I8Rows { w, kernel }, nbx, nby, b.i8, RowScorerKind::I8)
    }

    fn with<R: RowProducts>(
        r: R,
        nbx: usize,
        nby: usize,
        b: StreamBuffers<R>,
        kind: impl FnOnce(Stream<R>) -> RowScorerKind<'w>,
    ) -> Self {
        let (_, bw, bh, _) = r.dims();
        let kind = if nbx < bw || nby < bh {
            RowScorerKind::Empty
        } else {
            kind(Stream::with_buffers(r, nbx, 0, nby + 1 - bh, b))
        };
        Self { kind, nby, pushed: 0 }
    }

    /// Its allocations, for the next scorer.
    pub(crate) fn into_buffers(self) -> ScorerBuffers {
        let mut b = ScorerBuffers::default();
        match self.kind {
            RowScorerKind::Empty => {}
            RowScorerKind::F32(s) => b.f32 = s.into_buffers(),
            RowScorerKind::I8(s) => b.i8 = s.into_buffers(),
        }
        b
    }

    /// Windows across and down.
    pub(crate) fn windows(&self) -> (usize, usize) {
        match &self.kind {
            RowScorerKind::Empty => (0, 0),
            RowScorerKind::F32(s) => (s.nwx, s.rows),
            RowScorerKind::I8(s) => (s.nwx, s.rows),
        }
    }

    /// Add the grid's next block row (`nbx` blocks of the model's block length; panics on a
    /// shorter row or a row past the `nby`-th, like slicing).
    pub(crate) fn push(&mut self, row: &[f32]) {
        assert!(
            self.pushed < self.nby,
            "more than the grid's {} block rows",
            self.nby
        );
        self.pushed += 1;
        match &mut self.kind {
            RowScorerKind::Empty => {}
            RowScorerKind::F32(s) => s.push(row),
            RowScorerKind::I8(s) => s.push(row),
        }
    }

    /// The scores of every window, row-major ([`RowScorer::windows`]), into `scores` (which must
    /// hold that many values; extra values are untouched). Call after the last row.
    pub(crate) fn finish(&self, scores: &mut [f32]) {
        debug_assert_eq!(self.pushed, self.nby, "every block row pushed");
        let (nwx, nwy) = self.windows();
        let scores = &mut scores[..nwx * nwy];
        match &self.kind {
            RowScorerKind::Empty => {}
            RowScorerKind::F32(s) => s.finish(scores),
            RowScorerKind::I8(s) => s.finish(scores),
        }
    }
}
