//! Linear-SVM window scores of a HOG block grid, computed as a matrix product.
//!
//! # Method
//!
//! A window whose top-left block is `(wx, wy)` scores
//! `s(wx, wy) = b + Σ_{by<bh} Σ_{bx<bw} w_k · B(wx+bx, wy+by)`, `k = bx·bh + by` (OpenCV's block
//! order), where `B` is a normalised block (36 values) and `w_k` the model's weight slice for block
//! position `k`. Instead of one 36-long dot product per (window, block) pair with a horizontal sum
//! each time, every block row `r` of the grid is multiplied once by the `36 x 105` weight matrix:
//!
//! `P_r[k][x] = Σ_i B(x, r)[i] · W[i][k]` (a GEMM, `nbx x 36` times `36 x 105`),
//!
//! and a window score is a sum of 105 entries of `P`:
//! `s(wx, wy) = b + Σ_{by} Σ_{bx} P_{wy+by}[k(bx, by)][wx+bx]`. The second step is a plain
//! element-wise add of rows of `P` (vectorised over `wx`). Positions are numbered row by row,
//! `k = by·bw + bx` (the weights are permuted once from OpenCV's `bx·bh + by`), so a block row
//! needs one range of positions: row `r` is block row `by = r − wy` of window rows `wy` only, so
//! near the top and bottom of a level it needs fewer than `bh` of them, and only those products
//! are computed (`Stream`: 18 % of all products at 1080p, 44 levels, are never summed, most of
//! them in the small levels). Block rows can also arrive one at a time from a producer that keeps
//! no grid ([`RowScorer`]). The multiply count is the same as the
//! direct method (one product per block and block position) but it runs register-blocked, 8 (AVX2,
//! NEON as two vectors of 4) or 16 (AVX-512) blocks per vector, with no horizontal sums.
//!
//! # Kernels
//!
//! The products run on the kernel path of the process ([`crate::kernels::isa`]; scalar, AVX2,
//! AVX-512 or NEON), whose intrinsics live in `detect/kernels/{avx2,avx512,neon}.rs`; this module
//! keeps the scalar references and checks, once per call, every length a kernel's loads and
//! stores rely on (a failed check panics instead of reading out of bounds).
//!
//! # Exactness
//!
//! Every `P` entry is the same chain of fused multiply-adds over `i = 0..36` starting from 0 in
//! all kernels (the scalar reference uses [`f32::mul_add`]), and the window sums add in the fixed
//! order `by` then `bx` starting from the bias, so all dispatch paths give **bit-identical** scores,
//! for any thread count. Against the old per-window dot product (8 partial sums) scores differ only
//! by summation order (≈1e-6).
//!
//! # 8-bit path ([`ScorePrecision::I8`])
//!
//! An optional integer path, fast where the CPU has a u8·i8 dot product (`vpdpbusd`: AVX-512
//! VNNI on zmm, AVX-VNNI on ymm). Block values `v ∈ [0, 1]` (L2-Hys) become bytes
//! `q_v = round(180·v)` ([`quantise_block_value`]: clamped to `0..=180`, ties to even), the weights
//! become `q_w = round(s·w)`, `s = 127 / max|w|`, once per model ([`ScoreWeightsI8`]; an all-zero
//! model keeps `s = 1` and scores its bias). Then
//!
//! `P_r[k][x] = Σ_i q_v(x, r)[i] · q_w[i][k]` and `S(wx, wy) = Σ_{by} Σ_{bx} P_{wy+by}[bx·bh+by][wx+bx]`
//!
//! are **exact** i32 sums (`|S| ≤ 180·127·3780 < 2^31`; descriptors longer than
//! [`ScoreWeightsI8::MAX_DESCRIPTOR_LEN`] are refused), and the score is
//! `s(wx, wy) = b + S · (1/(180·s))` in f32 (one multiply, one add, the same code after every
//! kernel; the bias stays f32).
//!
//! Layout: each block row is quantised to bytes and transposed as dwords, `btq[g·nbxp + x]` = the
//! bytes of values `4g..4g+4` of block `x` (9 dwords for 36 values; a block length that is not a
//! multiple of 4 is zero-padded), and the weights as dwords `wq[g·nkp + k]`. The VNNI kernels
//! keep the f32 kernels' tiles, `acc[j] = vpdpbusd(acc[j], btq[g][x..x+16], broadcast(wq[g][k0+j]))`:
//! a quarter of their instructions (9 instead of 36 per block position). The other kernels:
//! - **AVX2 without VNNI** runs the same tiles with `vpmaddubsw` (two u8·i8 products in a
//!   saturating i16) widened by `vpmaddwd` against ones: 9 broadcasts + 27 operations per block
//!   position against 36 FMAs + 36 broadcasts in f32. Exact because the scale is 180, not 255:
//!   an L2-Hys block has `‖v‖₂ ≤ 1`, so two of its values sum to at most `√2` and quantise to at
//!   most 255 together, and `255·127 ≤ 32 767` (`detect/kernels/avx2.rs`). The scale was 255
//!   with a u16-pair `vpmaddwd` kernel before (18 + 18 + 18 per position); 180 costs 0.5 bit of
//!   block precision, measured in docs/detection.md ("8-bit SVM").
//! - **NEON** shifts the bytes to i8 (`v − 128`) and adds `128·Σ_i q_w[i][k]` back per position:
//!   `sdot` where the CPU has the dot product, else `smull`/`sadalp` (`detect/kernels/neon.rs`).
//!
//! **Which is faster.** `auto` ([`ScorePrecision::auto_for`]) picks this path where it was
//! measured faster than f32 (docs/detection.md, "8-bit SVM": every x86-64 path), f32 elsewhere;
//! choosing it where it is not faster is warned about when a detector is built, naming the missing
//! CPU feature ([`ScorePrecision::slow_reason`]).
//!
//! **Determinism.** Integer addition is associative, so the scalar reference and every kernel,
//! any strip split and any thread count give the same bits (tested), whatever order the sums run
//! in.
//!
//! **Error.** With `q_v = 180·v + e_v` and `q_w = s·w + e_w`, `|e| ≤ ½`, a score differs from the
//! exact one by `Σ (v·e_w/s + w·e_v/180 + e_v·e_w/(180·s))`, so
//! `|Δ| ≤ Σ|w|·½/180 + Σv·½/s + n·¼/(180·s)` with `Σv ≤ nk·√bl` for blocks of L2 norm ≤ 1
//! ([`ScoreWeightsI8::error_bound`]: 1.72 for OpenCV's people detector, `s` = 294.7). The bound is
//! loose because the rounding errors have both signs and mostly cancel: measured with OpenCV's
//! weights on kodim01 max |Δ| 0.040, mean 0.0081 (test; at the former scale 255: 0.032 / 0.0066,
//! and on the 1080p bench frame 0.038 / 0.0065).
//!
//! **Against OpenCV.** OpenCV has no 8-bit HOG scoring: the 8-bit scores are OpenCV's within the
//! error above, so windows within ≈0.05 of the hit threshold may flip. The OpenCV parity tests
//! and the golden detection hashes use the f32 path, which is unchanged.
//!
//! ```
//! use mosaicd::detect::{window_scores, ScoreWeights};
//! use mosaicd::features::hog::{block_grid_from_input, HogInput, HogOptions, HogSpec, Exec};
//! use mosaicd::image::Image;
//! let spec = HogSpec::new(&HogOptions::default()).unwrap();
//! let img = Image::<u8>::from_fn(80, 144, |x, y| ((x * 7 + y * 3) % 256) as u8);
//! let grid = block_grid_from_input(&spec, &HogInput::GreyU8(img.view())).unwrap();
//! let w = vec![0.01f32; spec.descriptor_len()];
//! let sw = ScoreWeights::new(&spec, &w, -0.5).unwrap();
//! let mut scores = vec![0.0; 3 * 3];
//! window_scores(&sw, &grid, Exec::Serial, &mut scores);
//! let d = grid.window_descriptor(&spec, 2, 1).unwrap();
//! let direct: f32 = d.iter().sum::<f32>() * 0.01 - 0.5;
//! assert!((scores[1 * 3 + 2] - direct).abs() < 1e-4);
//! // The 8-bit path: the same windows within the error bound.
//! use mosaicd::detect::{window_scores_i8, ScoreWeightsI8};
//! let sq = ScoreWeightsI8::new(&sw).unwrap();
//! let mut q = vec![0.0; 3 * 3];
//! window_scores_i8(&sq, &grid, Exec::Serial, &mut q);
//! assert!(q.iter().zip(&scores).all(|(a, b)| (a - b).abs() <= sq.error_bound()));
//! assert_eq!(q[1 * 3 + 2], sq.score_descriptor(&d));
//! ```
//!
//! # Layout
//!
//! This file is the facade (the math above, the re-exports below); imports point down the list:
//! `rows` ([`RowScorer`]) → `strips` (the strip driver, [`window_scores`]) → `products` (the f32 /
//! 8-bit kernel choice, transposes, quantisation, bounds checks, scalar references) → `weights`
//! ([`ScoreWeights`], [`ScoreWeightsI8`], [`ScoreError`]); `precision` ([`ScorePrecision`]) reads
//! `products` and `weights`.

mod precision;
mod products;
mod rows;
mod strips;
mod weights;

#[cfg(test)]
use super::kernels::quantise_block_value;
pub use precision::ScorePrecision;
pub(crate) use rows::{RowScorer, ScorerBuffers};
pub use strips::{window_scores, window_scores_i8};
pub use weights::{ScoreError, ScoreWeights, ScoreWeightsI8};

#[cfg(test)]
mod tests {
    use super::precision::*;
    use super::products::*;
    use super::rows::*;
    use super::strips::*;
    use super::weights::*;
    use super::*;
    use crate::features::hog::{block_grid, BlockGrid, Exec, HogInput, HogOptions, HogSpec};
    use crate::image::Image;
    use crate::kernels::{features, Isa};

    fn setup(w: usize, h: usize) -> (HogSpec, BlockGrid, Vec<f32>) {
        let spec = HogSpec::new(&HogOptions::default()).unwrap();
        let img = Image::<u8>::from_fn(w, h, |x, y| ((x * x + 7 * y * x + 3 * y) % 251) as u8);
        let mut grid = BlockGrid::empty();
        block_grid(&spec, &HogInput::GreyU8(img.view()), Exec::Serial, &mut grid).unwrap();
        let wts: Vec<f32> = (0..spec.descriptor_len() as u32)
            .map(|i| ((i.wrapping_mul(2654435761) >> 7) % 2001) as f32 / 1000.0 - 1.0)
            .collect();
        (spec, grid, wts)
    }

    #[test]
    fn kernel_paths_f32_scores_are_bit_identical_to_the_scalar_reference() {
        // 300 px → 36 blocks across: padded to 48 columns for the SIMD kernels. The f32 kernels
        // all run the same fused multiply-add chain, so the stated bound is 0: bit for bit.
        let (spec, grid, wts) = setup(300, 277);
        let sw = ScoreWeights::new(&spec, &wts, 0.25).unwrap();
        let (nwx, nwy) = grid.windows(&spec);
        let mut want = vec![0.0f32; nwx * nwy];
        window_scores_with(&sw, &grid, Exec::Serial, Isa::Scalar, &mut want);
        assert!(want.iter().any(|&v| v != 0.25), "the weights must matter");
        for isa in Isa::available() {
            for exec in [Exec::Serial, Exec::Parallel] {
                let mut got = vec![0.0f32; nwx * nwy];
                window_scores_with(&sw, &grid, exec, isa, &mut got);
                assert_eq!(bits(&got), bits(&want), "{isa} {exec:?}");
            }
        }
    }

    #[test]
    fn scores_equal_descriptor_dot_products() {
        // 700 px high → 72 window rows: two strips that share block rows.
        let (spec, grid, wts) = setup(100, 700);
        let sw = ScoreWeights::new(&spec, &wts, -0.75).unwrap();
        let (nwx, nwy) = grid.windows(&spec);
        let mut got = vec![0.0f32; nwx * nwy];
        window_scores(&sw, &grid, Exec::Parallel, &mut got);
        for wy in 0..nwy {
            for wx in 0..nwx {
                let d = grid.window_descriptor(&spec, wx, wy).unwrap();
                let want = d
                    .iter()
                    .zip(&wts)
                    .map(|(&a, &b)| a as f64 * b as f64)
                    .sum::<f64>()
                    - 0.75;
                assert!((got[wy * nwx + wx] as f64 - want).abs() < 1e-4, "{wx},{wy}");
            }
        }
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|v| v.to_bits()).collect()
    }

    /// Every 8-bit kernel of every path this CPU runs.
    fn every_i8_kernel() -> Vec<I8Kernel> {
        Isa::available().into_iter().flat_map(I8Kernel::all_for).collect()
    }

    #[test]
    fn kernel_paths_i8_scores_are_bit_identical_to_the_scalar_reference() {
        // 700 px high: two parallel strips; 300 px wide: 36 blocks padded to 48 columns.
        let (spec, grid, wts) = setup(300, 700);
        let sw = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &wts, 0.25).unwrap()).unwrap();
        let (nwx, nwy) = grid.windows(&spec);
        let mut want = vec![0.0f32; nwx * nwy];
        scores_i8_kernel(&sw, &grid, Exec::Serial, I8Kernel::Scalar, &mut want);
        assert!(want.iter().any(|&v| v != 0.25), "the weights must matter");
        let kernels = every_i8_kernel();
        for isa in Isa::available() {
            assert!(kernels.contains(&I8Kernel::for_isa(isa)), "{isa}");
        }
        for k in kernels {
            for exec in [Exec::Serial, Exec::Parallel] {
                let mut got = vec![0.0f32; nwx * nwy];
                scores_i8_kernel(&sw, &grid, exec, k, &mut got);
                assert_eq!(bits(&got), bits(&want), "{k:?} {exec:?}");
            }
        }
    }

    #[test]
    fn kernel_paths_row_scorers_equal_the_grid_scores() {
        // Rows pushed one at a time give the grid's scores bit for bit, f32 and 8-bit, on every
        // path; a grid smaller than a window has none.
        let (spec, grid, wts) = setup(300, 277);
        let sw = ScoreWeights::new(&spec, &wts, 0.25).unwrap();
        let sq = ScoreWeightsI8::new(&sw).unwrap();
        let (nbx, nby) = (grid.blocks_x(), grid.blocks_y());
        let (nwx, nwy) = grid.windows(&spec);
        for isa in Isa::available() {
            let mut want = vec![0.0f32; nwx * nwy];
            let mut got = vec![0.0f32; nwx * nwy];
            for i8 in [false, true] {
                let mut r = if i8 {
                    window_scores_i8_with(&sq, &grid, Exec::Parallel, isa, &mut want);
                    RowScorer::i8(&sq, isa, nbx, nby)
                } else {
                    window_scores_with(&sw, &grid, Exec::Parallel, isa, &mut want);
                    RowScorer::f32(&sw, isa, nbx, nby)
                };
                assert_eq!(r.windows(), (nwx, nwy));
                for by in 0..nby {
                    r.push(grid.block_row(by));
                }
                got.fill(f32::NAN);
                r.finish(&mut got);
                assert_eq!(bits(&got), bits(&want), "{isa} i8 {i8}");
            }
        }
        let mut small = RowScorer::f32(&sw, Isa::Scalar, 7, 14);
        assert_eq!(small.windows(), (0, 0));
        for _ in 0..14 {
            small.push(&[]);
        }
        let mut untouched = [1.5f32; 3];
        small.finish(&mut untouched);
        assert_eq!(untouched, [1.5; 3]);
    }

    #[test]
    fn kernel_paths_i8_products_are_exact_at_the_extremes() {
        // The largest pair sums an L2-normalised block can give, against weights ±127: two values
        // of 1/√2 side by side (q = 127 + 127: 254·127 = 32 258, the edge of AVX2's saturating
        // vpmaddubsw), a lone 1 (q = 180), and zeros (the −128 shift at the NEON kernels' edge).
        // Every kernel's products equal the i32 reference exactly.
        let spec = HogSpec::new(&HogOptions::default()).unwrap();
        let n = spec.descriptor_len();
        let h = std::f32::consts::FRAC_1_SQRT_2;
        for wsign in [1.0f32, -1.0] {
            let w: Vec<f32> = (0..n).map(|i| if i % 3 == 2 { -wsign } else { wsign }).collect();
            let sq = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &w, 0.0).unwrap()).unwrap();
            // 20 blocks of one row (padded to 32 columns): block x holds the pair at values
            // (2p, 2p+1), p = x mod 18, or (every 4th block) a lone 1 at value x mod 36.
            let row: Vec<f32> = (0..20 * 36)
                .map(|i| {
                    let (x, v) = (i / 36, i % 36);
                    match x % 4 {
                        3 => f32::from(u8::from(v == x % 36)),
                        _ if v / 2 == x % 18 => h,
                        _ => 0.0,
                    }
                })
                .collect();
            for blk in row.chunks_exact(36) {
                assert!(blk.iter().map(|v| v * v).sum::<f32>() <= 1.0 + 1e-6);
            }
            let run = |k: I8Kernel| {
                let (mut q, mut btq, mut out) =
                    (vec![0u8; 20 * 36], vec![0u32; sq.ng * 32], vec![0i32; sq.nk * 32]);
                quantise_row(&row, 36, 20, 32, k, &mut q, &mut btq);
                quant_products(&sq, &btq, 20, 32, 0..sq.nk, k, &mut out);
                (0..sq.nk)
                    .flat_map(|k| out[k * 32..][..20].to_vec())
                    .collect::<Vec<i32>>()
            };
            let want = run(I8Kernel::Scalar);
            // Block position 0 of block 0: the pair at values 0 and 1, both +wsign weights.
            assert_eq!(quantise_block_value(h), 127);
            assert_eq!(want[0], 127 * (sq.weight(0, 0) as i32 + sq.weight(1, 0) as i32));
            assert_eq!(want[0].abs(), 127 * 254);
            for k in every_i8_kernel() {
                assert_eq!(run(k), want, "{k:?} weights {wsign}");
            }
        }
    }

    #[test]
    fn i8_scores_equal_the_quantised_descriptor_scores() {
        let (spec, grid, wts) = setup(100, 300);
        let sw = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &wts, -0.75).unwrap()).unwrap();
        let (nwx, nwy) = grid.windows(&spec);
        let mut got = vec![0.0f32; nwx * nwy];
        window_scores_i8(&sw, &grid, Exec::Parallel, &mut got);
        for wy in 0..nwy {
            for wx in 0..nwx {
                let d = grid.window_descriptor(&spec, wx, wy).unwrap();
                assert_eq!(
                    got[wy * nwx + wx].to_bits(),
                    sw.score_descriptor(&d).to_bits(),
                    "{wx},{wy}"
                );
            }
        }
    }

    #[test]
    fn i8_scores_stay_within_the_bound_of_f32_with_opencv_weights_on_kodak() {
        use crate::detect::model::{Domain, LinearModel};
        let model = LinearModel::load(
            &crate::data::require("opencv_hog/default_people_detector_64x128.npy"),
            Domain::Colour,
        )
        .unwrap();
        let spec = model.hog_spec("test").unwrap();
        let img = crate::raw::load::load_rgb8(&crate::data::require("kodak/kodim01.png")).unwrap();
        let mut grid = BlockGrid::empty();
        block_grid(&spec, &HogInput::Rgb8(img.view()), Exec::Parallel, &mut grid).unwrap();
        let sw = ScoreWeights::new(&spec, &model.weights, model.bias).unwrap();
        let sq = ScoreWeightsI8::new(&sw).unwrap();
        let (nwx, nwy) = grid.windows(&spec);
        let (mut f, mut q) = (vec![0.0f32; nwx * nwy], vec![0.0f32; nwx * nwy]);
        window_scores(&sw, &grid, Exec::Parallel, &mut f);
        window_scores_i8(&sq, &grid, Exec::Parallel, &mut q);
        let d: Vec<f32> = f.iter().zip(&q).map(|(a, b)| (a - b).abs()).collect();
        let max = d.iter().fold(0.0f32, |m, &v| m.max(v));
        let mean = d.iter().sum::<f32>() / d.len() as f32;
        // The proven worst case (≈1.5 for these weights: loose, the sum of block values is bounded by 105·√36), plus the f32 path's own rounding.
        assert!(
            max <= sq.error_bound() + 1e-4,
            "max |Δ| {max} > bound {}",
            sq.error_bound()
        );
        // Measured: max 0.040, mean 0.0081 at block scale 180 (0.032 / 0.0066 at 255; rounding
        // errors mostly cancel); a wrong scale or layout gives errors of the order of the scores.
        eprintln!(
            "kodim01: {} windows, max |Δ| {max}, mean {mean}, bound {}",
            d.len(),
            sq.error_bound()
        );
        assert!(max < 0.05 && mean < 0.01, "max {max} mean {mean}");
    }

    #[test]
    fn quantisation_edge_cases() {
        assert_eq!(quantise_block_value(0.0), 0);
        assert_eq!(quantise_block_value(1.0), 180);
        assert_eq!(quantise_block_value(-0.25), 0);
        assert_eq!(quantise_block_value(1.5), 180);
        assert_eq!(quantise_block_value(f32::NAN), 0);
        assert_eq!(quantise_block_value(1.0 / 180.0), 1);
        assert_eq!(quantise_block_value(0.4 / 180.0), 0);
        assert_eq!(quantise_block_value(0.6 / 180.0), 1);
        // 22.5 and 67.5: ties to even.
        assert_eq!(quantise_block_value(0.125), 22);
        assert_eq!(quantise_block_value(0.375), 68);
        assert_eq!(quantise_block_value(0.5), 90);
        let spec = HogSpec::new(&HogOptions::default()).unwrap();
        // All-zero weights: every window scores the bias.
        let zero = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &[], 1.5).unwrap()).unwrap();
        assert_eq!(zero.weight_scale(), 1.0);
        let (_, grid, _) = setup(80, 144);
        let mut s = vec![0.0f32; 9];
        window_scores_i8(&zero, &grid, Exec::Serial, &mut s);
        assert_eq!(s, vec![1.5; 9]);
        // The largest weight maps to ±127 (s = 127 / (127/128) = 128), half steps round away
        // from zero.
        let mut w = vec![0.0f32; spec.descriptor_len()];
        (w[0], w[1], w[2], w[37]) = (-127.0 / 128.0, 0.25, -0.5 / 128.0, 1.5 / 128.0);
        let q = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &w, 0.0).unwrap()).unwrap();
        assert_eq!(q.weight_scale(), 128.0);
        // w[37] is value 1 of descriptor position 1 (bx 0, by 1): our position by·bw + bx = 7.
        assert_eq!(
            [q.weight(0, 0), q.weight(1, 0), q.weight(2, 0), q.weight(1, 7)],
            [-127, 32, -1, 2]
        );
        // One block of ones against those weights: (−127 + 32 − 1)·180 / (180·128).
        let mut d = vec![0.0f32; spec.descriptor_len()];
        d[..36].fill(1.0);
        assert!((q.score_descriptor(&d) + 0.75).abs() < 1e-6);
    }

    #[test]
    fn kernel_paths_quantisers_give_the_scalar_bytes_at_the_edges() {
        // 21 blocks of 36 values (756: a partial last vector and a partial gather of 5 blocks),
        // with ties, out-of-range values and NaN.
        let special = [
            0.0,
            1.0,
            -0.0,
            -1.0,
            2.0,
            f32::NAN,
            f32::INFINITY,
            0.5,
            0.375,
            1e-9,
        ];
        let row: Vec<f32> = (0..21 * 36)
            .map(|i| special.get(i % 97).copied().unwrap_or((i as f32 * 0.618).fract()))
            .collect();
        let run = |k| {
            let (mut q, mut btq) = (vec![0u8; 21 * 36], vec![1u32; 18 * 32]);
            quantise_row(&row, 36, 21, 32, k, &mut q, &mut btq);
            (q, btq)
        };
        let want = run(I8Kernel::Scalar);
        assert_eq!(want.0[..10], [0, 180, 0, 0, 180, 0, 180, 90, 68, 0]);
        for k in every_i8_kernel() {
            let got = run(k);
            assert_eq!(got.0, want.0, "{k:?}");
            for x in 0..21 {
                let block = &want.0[x * 36..][..36];
                for g in 0..9 {
                    assert_eq!(
                        got.1[g * 32 + x].to_le_bytes(),
                        block[4 * g..][..4],
                        "{k:?} {x} dword {g}"
                    );
                }
            }
        }
    }

    #[test]
    fn block_lengths_off_a_multiple_of_four_are_zero_padded() {
        // Two blocks of 6 values → 2 dwords each; 16 padded columns.
        let row = [1.0, 0.0, 0.5, 1.0, 0.2, 0.4, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0];
        let (mut q, mut btq) = (vec![9u8; 2 * 8], vec![7u32; 2 * 16]);
        quantise_row(&row, 6, 2, 16, I8Kernel::Scalar, &mut q, &mut btq);
        assert_eq!(btq[0], u32::from_le_bytes([180, 0, 90, 180]));
        assert_eq!(btq[16], u32::from_le_bytes([36, 72, 0, 0]));
        assert_eq!(btq[1], u32::from_le_bytes([0, 180, 180, 0]));
        assert_eq!(btq[17], u32::from_le_bytes([180, 180, 0, 0]));
        assert_eq!(btq[2], 7, "columns past nbx are not written");
    }

    #[test]
    fn precisions_parse_by_name_and_long_descriptors_are_refused() {
        for p in ScorePrecision::ALL {
            assert_eq!(p.to_string().parse::<ScorePrecision>().unwrap(), p);
        }
        assert_eq!("I8".parse::<ScorePrecision>().unwrap(), ScorePrecision::I8);
        assert_eq!(ScorePrecision::default(), ScorePrecision::F32);
        let e = "f16".parse::<ScorePrecision>().unwrap_err().to_string();
        assert!(e.contains("f16") && e.contains("f32, i8, auto"), "{e}");
        assert_eq!("AUTO".parse::<ScorePrecision>().unwrap(), ScorePrecision::auto());
        // 255 bins: 7·15 blocks of 1020 values overflow i32 window sums.
        let spec = HogSpec::new(&HogOptions {
            nbins: 255,
            ..HogOptions::default()
        })
        .unwrap();
        let e = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &[1.0], 0.0).unwrap()).unwrap_err();
        assert_eq!(
            e,
            ScoreError::DescriptorTooLong {
                len: 107_100,
                max: 93_940
            }
        );
    }

    #[test]
    fn a_grid_smaller_than_a_window_leaves_scores_alone() {
        let spec = HogSpec::new(&HogOptions::default()).unwrap();
        let sw = ScoreWeights::new(&spec, &[], 1.0).unwrap();
        let mut s = vec![7.0f32; 3];
        window_scores(&sw, &BlockGrid::empty(), Exec::Serial, &mut s);
        assert_eq!(s, vec![7.0; 3]);
    }

    #[test]
    fn auto_picks_i8_only_on_the_measured_paths_and_slow_settings_say_why() {
        let f = features();
        for isa in Isa::ALL {
            let auto = ScorePrecision::auto_for(isa);
            let x86 = cfg!(target_arch = "x86_64");
            let measured = match isa {
                Isa::Neon if isa.is_available() => false,
                // Unavailable paths run the scalar kernels.
                _ => x86,
            };
            assert_eq!(auto == ScorePrecision::I8, measured, "{isa}");
            assert_eq!(ScorePrecision::F32.slow_reason(isa), None);
            assert_eq!(auto.slow_reason(isa), None, "{isa}");
            let slow = ScorePrecision::I8.slow_reason(isa);
            if isa == Isa::Neon && isa.is_available() && !f.dotprod {
                let why = slow.unwrap();
                assert!(why.contains("dotprod") && why.contains("auto"), "{why}");
            } else {
                assert_eq!(slow, None, "{isa}");
            }
        }
        assert_eq!(
            ScorePrecision::auto(),
            ScorePrecision::auto_for(crate::kernels::isa())
        );
    }

    #[test]
    fn overflowing_window_geometry_is_refused_with_its_sizes() {
        // Input-driven geometry (issue 24): sizes whose products wrap are refused with the
        // values, before anything is indexed.
        let huge = usize::MAX / 4;
        for (bw, bh, bl) in [
            (7, huge, 36),
            (huge, 5, 1),
            (1, usize::MAX, 1),
            (3, 3, usize::MAX / 2),
        ] {
            assert_eq!(
                gemm_sizes(bw, bh, bl),
                Err(ScoreError::Geometry {
                    blocks_x: bw,
                    blocks_y: bh,
                    block_len: bl
                }),
                "{bw} {bh} {bl}"
            );
        }
        // 105 positions: whole tiles of 12 (108), then one tile of the widest kernel (21) more.
        assert_eq!(gemm_sizes(7, 15, 36), Ok((105, 129, 36 * 129)));
        // The crafted model of the report: a 32 x 6148914691236517216 window of 2 bins, whose
        // descriptor length wraps to 8. Refused here if the HOG spec lets it through.
        let opts = HogOptions {
            win_width: 32,
            win_height: 6_148_914_691_236_517_216,
            nbins: 2,
            ..HogOptions::default()
        };
        if let Ok(spec) = HogSpec::new(&opts) {
            let e = ScoreWeights::new(&spec, &[1.0; 8], 0.0).unwrap_err();
            assert!(
                matches!(
                    e,
                    ScoreError::Geometry {
                        blocks_x: 3,
                        block_len: 8,
                        ..
                    }
                ),
                "{e}"
            );
            assert!(
                e.to_string().contains("3x768614336404564651 blocks of 8 values"),
                "{e}"
            );
        }
    }

    #[test]
    #[should_panic(expected = "block products out of bounds")]
    fn product_bounds_are_checked_in_release_builds_too() {
        let (spec, _, wts) = setup(80, 144);
        let sw = ScoreWeights::new(&spec, &wts, 0.0).unwrap();
        // A transposed row one column short of 16 padded columns.
        let (bt, mut out) = (vec![0.0f32; 36 * 16 - 1], vec![0.0f32; 105 * 16]);
        block_products(&sw, &bt, 10, 16, 0..sw.nk, crate::kernels::isa(), &mut out);
    }

    /// Block-product speed of every kernel on one block row of a 1080p level 0 (239 blocks),
    /// quantiser or transpose included: `cargo test --release --lib svm_kernel_speed --
    /// --ignored --nocapture`. Numbers in docs/detection.md, "8-bit SVM".
    #[test]
    #[ignore = "a timing, for release builds by hand"]
    fn svm_kernel_speed() {
        use std::hint::black_box;
        use std::time::Instant;
        let (spec, _, wts) = setup(80, 144);
        let sw = ScoreWeights::new(&spec, &wts, 0.0).unwrap();
        let sq = ScoreWeightsI8::new(&sw).unwrap();
        let (nbx, nbxp, reps) = (239, 240, 400);
        let row: Vec<f32> = (0..nbx * 36)
            .map(|i| ((i * 7919) % 1000) as f32 / 4000.0)
            .collect();
        let time = |f: &mut dyn FnMut()| {
            f();
            let t = Instant::now();
            for _ in 0..reps {
                f();
            }
            t.elapsed().as_secs_f64() * 1e6 / reps as f64
        };
        for isa in Isa::available() {
            let (mut bt, mut out) = (vec![0.0f32; 36 * nbxp], vec![0.0f32; sw.nk * nbxp]);
            let us = time(&mut || {
                transpose_row(&row, 36, nbx, nbxp, &mut bt);
                block_products(&sw, &bt, nbx, nbxp, 0..sw.nk, isa, &mut out);
                black_box(&out);
            });
            eprintln!("f32 {isa}: {us:.1} us per block row");
        }
        for k in every_i8_kernel() {
            let (mut q, mut btq, mut out) = (
                vec![0u8; 36 * nbxp],
                vec![0u32; sq.ng * nbxp],
                vec![0i32; sq.nk * nbxp],
            );
            let us = time(&mut || {
                quantise_row(&row, 36, nbx, nbxp, k, &mut q, &mut btq);
                quant_products(&sq, &btq, nbx, nbxp, 0..sq.nk, k, &mut out);
                black_box(&out);
            });
            eprintln!("i8 {k:?}: {us:.1} us per block row");
        }
    }
}
