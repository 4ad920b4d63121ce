//! The strip driver: window scores of a whole block grid ([`window_scores`], [`window_scores_i8`]), in parallel strips of window rows, each a [`Stream`] of block rows.

use std::ops::{AddAssign, Range};

use rayon::prelude::*;

use super::products::{
    block_products, f32_kernel, quant_products, quantise_row, transpose_row, I8Kernel, PAD_COLUMNS,
};
use super::weights::{ScoreWeights, ScoreWeightsI8};
use crate::detect::kernels::add_window_row;
use crate::features::hog::{BlockGrid, Exec};
use crate::kernels::Isa;

/// Window rows per parallel task (1080p level 0 has 120; each task recomputes 14 block rows).
pub(super) const SCORE_STRIP_ROWS: usize = 64;

/// Scores of every window of `grid` (row-major, `grid.windows()` wide) into `scores`, with the
/// kernel path of this process ([`crate::kernels::isa`]). `scores` must hold `nwx · nwy` values
/// (extra values are untouched).
pub fn window_scores(w: &ScoreWeights, grid: &BlockGrid, exec: Exec, scores: &mut [f32]) {
    window_scores_with(w, grid, exec, crate::kernels::isa(), scores)
}

/// [`window_scores`] on kernel path `isa` (a path this CPU cannot run falls back to the scalar
/// reference). Every path gives the same bits.
pub(crate) fn window_scores_with(
    w: &ScoreWeights,
    grid: &BlockGrid,
    exec: Exec,
    isa: Isa,
    scores: &mut [f32],
) {
    let kernel = f32_kernel(isa);
    scores_by_strips(&F32Rows { w, kernel }, grid, exec, scores)
}

/// [`window_scores`] on the 8-bit path ([`ScorePrecision::I8`](super::ScorePrecision::I8), see the module docs), with the
/// 8-bit kernel of this process's kernel path.
pub fn window_scores_i8(w: &ScoreWeightsI8, grid: &BlockGrid, exec: Exec, scores: &mut [f32]) {
    window_scores_i8_with(w, grid, exec, crate::kernels::isa(), scores)
}

/// [`window_scores_i8`] on kernel path `isa` (its fastest 8-bit kernel on this CPU; a path this
/// CPU cannot run falls back to the scalar reference). Every kernel gives the same bits.
pub(crate) fn window_scores_i8_with(
    w: &ScoreWeightsI8,
    grid: &BlockGrid,
    exec: Exec,
    isa: Isa,
    scores: &mut [f32],
) {
    scores_i8_kernel(w, grid, exec, I8Kernel::for_isa(isa), scores)
}

/// [`window_scores_i8`] with one 8-bit kernel (the scalar one if this CPU cannot run it).
pub(super) fn scores_i8_kernel(
    w: &ScoreWeightsI8,
    grid: &BlockGrid,
    exec: Exec,
    kernel: I8Kernel,
    scores: &mut [f32],
) {
    let kernel = kernel.or_scalar();
    scores_by_strips(&I8Rows { w, kernel }, grid, exec, scores)
}

/// One precision's block-row products and final scores, for the strip driver [`scores_by_strips`].
pub(super) trait RowProducts: Sync {
    /// Element of the products and window sums (f32, or exact i32).
    type Acc: Copy + Default + AddAssign + Send;
    /// Per-strip buffers of the transposed block row.
    type Scratch: Default;
    /// Block length, blocks per window (x, y), block positions per window.
    fn dims(&self) -> (usize, usize, usize, usize);
    /// What a window sum starts from.
    fn start(&self) -> Self::Acc;
    /// `s` made the zeroed buffers of a grid `nbxp` columns wide (its allocation reused).
    fn reset_scratch(&self, nbxp: usize, s: &mut Self::Scratch);
    /// `out[k·nbxp + x]` = product of block `x < nbx` of `row` with the weights of position `k`,
    /// for the positions `k ∈ ks` (the others are left as they are).
    fn products(
        &self,
        row: &[f32],
        nbx: usize,
        nbxp: usize,
        ks: Range<usize>,
        s: &mut Self::Scratch,
        out: &mut [Self::Acc],
    );
    /// Window sums to scores.
    fn finish(&self, sums: &[Self::Acc], scores: &mut [f32]);
    /// [`add_window_row`] with this path's instruction set.
    fn add_row(&self, row: &mut [Self::Acc], pr: &[Self::Acc], by: usize, bw: usize, nbxp: usize);
}

/// The f32 path: transposed block rows, f32 products, window sums from the bias.
#[derive(Clone, Copy)]
pub(super) struct F32Rows<'a> {
    pub(super) w: &'a ScoreWeights,
    pub(super) kernel: Isa,
}

impl RowProducts for F32Rows<'_> {
    type Acc = f32;
    type Scratch = Vec<f32>;
    fn dims(&self) -> (usize, usize, usize, usize) {
        (self.w.bl, self.w.bw, self.w.bh, self.w.nk)
    }
    fn start(&self) -> f32 {
        self.w.bias
    }
    fn reset_scratch(&self, nbxp: usize, bt: &mut Vec<f32>) {
        bt.clear();
        bt.resize(self.w.bl * nbxp, 0.0);
    }
    fn products(
        &self,
        row: &[f32],
        nbx: usize,
        nbxp: usize,
        ks: Range<usize>,
        bt: &mut Vec<f32>,
        out: &mut [f32],
    ) {
        transpose_row(row, self.w.bl, nbx, nbxp, bt);
        block_products(self.w, bt, nbx, nbxp, ks, self.kernel, out);
    }
    fn finish(&self, sums: &[f32], scores: &mut [f32]) {
        scores.copy_from_slice(sums);
    }
    fn add_row(&self, row: &mut [f32], pr: &[f32], by: usize, bw: usize, nbxp: usize) {
        match self.kernel {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `kernel` is a path this CPU runs (`f32_kernel`), so it has AVX2.
            Isa::Avx2 | Isa::Avx512 => unsafe {
                crate::detect::kernels::avx2::add_window_row_f32(row, pr, by, bw, nbxp)
            },
            _ => add_window_row(row, pr, by, bw, nbxp),
        }
    }
}

/// The 8-bit path: quantised, dword-transposed block rows, exact i32 products and window sums.
#[derive(Clone, Copy)]
pub(super) struct I8Rows<'a> {
    pub(super) w: &'a ScoreWeightsI8,
    pub(super) kernel: I8Kernel,
}

impl RowProducts for I8Rows<'_> {
    type Acc = i32;
    /// The quantised row (`4·ng` bytes per block) and its dword transpose.
    type Scratch = (Vec<u8>, Vec<u32>);
    fn dims(&self) -> (usize, usize, usize, usize) {
        (self.w.bl, self.w.bw, self.w.bh, self.w.nk)
    }
    fn start(&self) -> i32 {
        0
    }
    fn reset_scratch(&self, nbxp: usize, (q, btq): &mut (Vec<u8>, Vec<u32>)) {
        q.clear();
        q.resize(4 * self.w.ng * nbxp, 0);
        btq.clear();
        btq.resize(self.w.ng * nbxp, 0);
    }
    fn products(
        &self,
        row: &[f32],
        nbx: usize,
        nbxp: usize,
        ks: Range<usize>,
        s: &mut (Vec<u8>, Vec<u32>),
        out: &mut [i32],
    ) {
        let (q, btq) = s;
        quantise_row(row, self.w.bl, nbx, nbxp, self.kernel, q, btq);
        quant_products(self.w, btq, nbx, nbxp, ks, self.kernel, out);
    }
    fn finish(&self, sums: &[i32], scores: &mut [f32]) {
        for (s, &v) in scores.iter_mut().zip(sums) {
            *s = self.w.score_from_sum(v);
        }
    }
    fn add_row(&self, row: &mut [i32], pr: &[i32], by: usize, bw: usize, nbxp: usize) {
        match self.kernel {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: every non-scalar x86-64 kernel runs only with AVX2 (`is_runnable`), and
            // `scores_i8_kernel` replaced a kernel this CPU cannot run by the scalar one.
            I8Kernel::Avx2Maddubs | I8Kernel::AvxVnni | I8Kernel::Avx512Vnni => unsafe {
                crate::detect::kernels::avx2::add_window_row_i32(row, pr, by, bw, nbxp)
            },
            _ => add_window_row(row, pr, by, bw, nbxp),
        }
    }
}

/// The window sums of window rows `[first, first + rows)` of a grid `nbx` blocks wide, made from
/// its block rows `first, first + 1, …` as they are pushed: each row's products are computed once
/// into a small buffer and added to the window rows they belong to.
pub(super) struct Stream<R: RowProducts> {
    pub(super) r: R,
    pub(super) nbx: usize,
    pub(super) nbxp: usize,
    pub(super) nwx: usize,
    pub(super) first: usize,
    pub(super) rows: usize,
    /// The index of the next block row.
    pub(super) next: usize,
    pub(super) scratch: R::Scratch,
    pub(super) pr: Vec<R::Acc>,
    pub(super) sums: Vec<R::Acc>,
}

impl<R: RowProducts> Stream<R> {
    /// Window rows `[first, first + rows)` of a grid `nbx` blocks wide (`nbx ≥ bw`).
    pub(super) fn new(r: R, nbx: usize, first: usize, rows: usize) -> Self {
        Self::with_buffers(r, nbx, first, rows, Default::default())
    }

    /// [`Stream::new`] in the allocations `b` (whatever they hold).
    pub(super) fn with_buffers(r: R, nbx: usize, first: usize, rows: usize, b: StreamBuffers<R>) -> Self {
        let (_, bw, _, nk) = r.dims();
        let nwx = nbx + 1 - bw;
        // Columns padded with zero blocks to whole vectors of the widest kernel.
        let nbxp = nbx.div_ceil(PAD_COLUMNS) * PAD_COLUMNS;
        let (mut scratch, mut pr, mut sums) = b;
        r.reset_scratch(nbxp, &mut scratch);
        // Products are written before they are read (`push`); only the sums start from a value.
        pr.resize(nk * nbxp, R::Acc::default());
        sums.clear();
        sums.resize(rows * nwx, r.start());
        Self {
            scratch,
            pr,
            sums,
            r,
            nbx,
            nbxp,
            nwx,
            first,
            rows,
            next: first,
        }
    }

    /// The block rows the window rows need: `[first, first + rows + bh − 1)`.
    pub(super) fn needed(&self) -> std::ops::Range<usize> {
        let bh = self.r.dims().2;
        self.first..self.first + self.rows + bh - 1
    }

    /// Add the next block row (`nbx` blocks).
    pub(super) fn push(&mut self, row: &[f32]) {
        let (bl, bw, bh, _) = self.r.dims();
        assert!(
            row.len() >= self.nbx * bl,
            "a block row of {} values, {} blocks of {bl} wanted",
            row.len(),
            self.nbx
        );
        let row_index = self.next;
        self.next += 1;
        // The window rows `wy = row_index − by` inside this stream take block row `by` of their
        // window from this row: `by` in `[lo, hi]`, the positions `[lo·bw, (hi + 1)·bw)`.
        let last_wy = self.first + self.rows - 1;
        let lo = row_index.saturating_sub(last_wy);
        let hi = (bh - 1).min(row_index.saturating_sub(self.first));
        if row_index < self.first || lo > hi {
            return;
        }
        self.r.products(
            row,
            self.nbx,
            self.nbxp,
            lo * bw..(hi + 1) * bw,
            &mut self.scratch,
            &mut self.pr,
        );
        // Window row wy = row_index − by gets block row `by` of its window from this block row.
        for by in 0..bh {
            let Some(wy) = row_index.checked_sub(by) else {
                break;
            };
            if wy < self.first || wy >= self.first + self.rows {
                continue;
            }
            let nwx = self.nwx;
            self.r.add_row(
                &mut self.sums[(wy - self.first) * nwx..][..nwx],
                &self.pr,
                by,
                bw,
                self.nbxp,
            );
        }
    }

    /// The scores (`rows · nwx` values).
    pub(super) fn finish(&self, scores: &mut [f32]) {
        self.r.finish(&self.sums, scores);
    }

    /// Its allocations, for the next stream.
    pub(super) fn into_buffers(self) -> StreamBuffers<R> {
        (self.scratch, self.pr, self.sums)
    }
}

/// The allocations of a [`Stream`]: scratch, products, window sums.
pub(super) type StreamBuffers<R> = (
    <R as RowProducts>::Scratch,
    Vec<<R as RowProducts>::Acc>,
    Vec<<R as RowProducts>::Acc>,
);

/// Window scores of `grid` with one precision's products (see [`window_scores_with`]).
pub(super) fn scores_by_strips<R: RowProducts + Copy>(
    r: &R,
    grid: &BlockGrid,
    exec: Exec,
    scores: &mut [f32],
) {
    let (bl, bw, bh, _) = r.dims();
    let (nbx, nby) = (grid.blocks_x(), grid.blocks_y());
    if nbx < bw || nby < bh || grid.block_len() != bl {
        return;
    }
    let (nwx, nwy) = (nbx + 1 - bw, nby + 1 - bh);
    // A strip of window rows walks the block rows it needs in ascending order ([`Stream`]).
    // Parallel strips recompute the bh − 1 block rows they share (≈10 % at 1080p) instead of
    // holding every row's products (13 MB at 1080p); serially the whole grid is one strip. A
    // window's sum has the same order in any split (block rows ascending, then block columns), so
    // the same bits (on the 8-bit path the sums are integers: any order gives the same bits).
    let strip_work = |(s, chunk): (usize, &mut [f32])| {
        let mut st = Stream::new(*r, nbx, s * SCORE_STRIP_ROWS, chunk.len() / nwx);
        for row_index in st.needed() {
            st.push(grid.block_row(row_index));
        }
        st.finish(chunk);
    };
    let scores = &mut scores[..nwx * nwy];
    match exec {
        Exec::Parallel => scores
            .par_chunks_mut(nwx * SCORE_STRIP_ROWS)
            .enumerate()
            .for_each(strip_work),
        // One strip: nothing to share, so no block row is computed twice.
        Exec::Serial => strip_work((0, scores)),
    }
}
