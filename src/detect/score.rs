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
//! use mosaicd::detect::score::{window_scores, ScoreWeights};
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
//! use mosaicd::detect::score::{window_scores_i8, ScoreWeightsI8};
//! let sq = ScoreWeightsI8::new(&sw).unwrap();
//! let mut q = vec![0.0; 3 * 3];
//! window_scores_i8(&sq, &grid, Exec::Serial, &mut q);
//! assert!(q.iter().zip(&scores).all(|(a, b)| (a - b).abs() <= sq.error_bound()));
//! assert_eq!(q[1 * 3 + 2], sq.score_descriptor(&d));
//! ```

use std::ops::{AddAssign, Range};
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use super::kernels::{add_window_row, TILE_K_AVX512, TILE_K_NARROW};
pub use super::kernels::{quantise_block_value, BLOCK_QUANT_SCALE};
use crate::features::hog::{BlockGrid, Exec, HogSpec};
use crate::kernels::{features, Isa};

/// Window rows per parallel task (1080p level 0 has 120; each task recomputes 14 block rows).
const SCORE_STRIP_ROWS: usize = 64;
/// Block columns are zero-padded to a multiple of this (the widest kernel's vector).
const PAD_COLUMNS: usize = 16;

/// The model re-laid out for the GEMM: `wt[i·nkp + k]` = weight of value `i` of block position `k`,
/// zero-padded to `nkp` positions (whole tiles for every kernel, plus one: see `gemm_sizes`).
/// Positions are numbered row by row, `k = by·bw + bx` (OpenCV's descriptor runs column by
/// column, `bx·bh + by`), so the positions one block row needs form one range (`Stream::push`).
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreWeights {
    wt: Vec<f32>,
    bias: f32,
    /// Block length (36).
    bl: usize,
    /// Blocks per window (7, 15).
    bw: usize,
    bh: usize,
    /// Block positions per window (105) and its padded count.
    nk: usize,
    nkp: usize,
}

/// The position in OpenCV's descriptor order (`bx·bh + by`) of our block position `k = by·bw + bx`.
fn descriptor_position(k: usize, bw: usize, bh: usize) -> usize {
    (k % bw) * bh + k / bw
}

/// `n` rounded up to a multiple of `m`, `None` on overflow.
fn round_up(n: usize, m: usize) -> Option<usize> {
    n.div_ceil(m).checked_mul(m)
}

/// The weight matrix of a window of `bw x bh` blocks of `bl` values: block positions `nk`, their
/// count padded to whole tiles of every kernel plus one more tile, `nkp` (a kernel's last tile may
/// run past the positions it was asked for; its results are not stored, and a range of positions
/// `[k0, k1)` then still reads inside the matrix: `k0 + round_up(k1 − k0) ≤ nk + tile ≤ nkp`), and
/// the matrix length `bl·nkp`, in checked arithmetic.
fn gemm_sizes(bw: usize, bh: usize, bl: usize) -> Result<(usize, usize, usize), ScoreError> {
    let refuse = || ScoreError::Geometry {
        blocks_x: bw,
        blocks_y: bh,
        block_len: bl,
    };
    let nk = bw.checked_mul(bh).ok_or_else(refuse)?;
    let nkp = round_up(nk, TILE_K_NARROW)
        .zip(round_up(nk, TILE_K_AVX512))
        .and_then(|(a, b)| a.max(b).checked_add(TILE_K_NARROW.max(TILE_K_AVX512)))
        .ok_or_else(refuse)?;
    let len = bl.checked_mul(nkp).ok_or_else(refuse)?;
    Ok((nk, nkp, len))
}

impl ScoreWeights {
    /// From a weight vector in OpenCV descriptor order (`spec.descriptor_len()` values; a shorter
    /// vector is zero-extended, a longer one cut) and the bias.
    ///
    /// The geometry comes from the model file: sizes whose products overflow, or whose weight
    /// matrix cannot be allocated, are refused ([`ScoreError::Geometry`]) before anything is
    /// indexed.
    pub fn new(spec: &HogSpec, weights: &[f32], bias: f32) -> Result<Self, ScoreError> {
        let (bw, bh) = spec.blocks_per_window();
        let bl = spec.block_len();
        let (nk, nkp, len) = gemm_sizes(bw, bh, bl)?;
        let mut wt = Vec::new();
        wt.try_reserve_exact(len).map_err(|_| ScoreError::Geometry {
            blocks_x: bw,
            blocks_y: bh,
            block_len: bl,
        })?;
        wt.resize(len, 0.0f32);
        for k in 0..nk {
            let m = descriptor_position(k, bw, bh);
            for i in 0..bl {
                // m·bl + i < nk·bl ≤ nkp·bl = len: no overflow.
                wt[i * nkp + k] = weights.get(m * bl + i).copied().unwrap_or(0.0);
            }
        }
        Ok(Self {
            wt,
            bias,
            bl,
            bw,
            bh,
            nk,
            nkp,
        })
    }
}

/// Arithmetic of the SVM stage ([`crate::detect::DetectorOptions::svm`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum ScorePrecision {
    /// f32 products (fused multiply-adds) and window sums: OpenCV's scores within ≈1e-6.
    #[default]
    F32,
    /// Block values as u8, weights as i8, exact i32 products and window sums; scores within
    /// [`ScoreWeightsI8::error_bound`] of the exact ones (module docs, "8-bit path").
    I8,
}

/// The settings `compute.svm` and `--svm` accept: the precisions' names and `auto`.
pub const PRECISION_SETTINGS: [&str; 3] = ["f32", "i8", "auto"];

/// Whether the start-up warning of [`ScorePrecision::warn_if_slow`] was given.
static WARNED_SLOW: AtomicBool = AtomicBool::new(false);

impl ScorePrecision {
    /// Every precision, in the order of [`Self::name`]'s list.
    pub const ALL: [Self; 2] = [Self::F32, Self::I8];

    /// The name used by the CLI (`--svm`) and the daemon config (`compute.svm`): `f32`, `i8`.
    pub fn name(self) -> &'static str {
        match self {
            Self::F32 => "f32",
            Self::I8 => "i8",
        }
    }

    /// What `auto` means on this process's kernel path ([`crate::kernels::isa`]): see
    /// [`Self::auto_for`].
    pub fn auto() -> Self {
        Self::auto_for(crate::kernels::isa())
    }

    /// The precision `auto` picks on kernel path `isa` of this CPU: [`Self::I8`] where its kernel
    /// was measured faster than the f32 one (docs/detection.md, "8-bit SVM"), [`Self::F32`]
    /// elsewhere:
    /// - AVX-512 with AVX-512 VNNI (`vpdpbusd` zmm; SVM stage 2.6–2.8x): i8;
    /// - AVX2 or AVX-512 with AVX-VNNI (`vpdpbusd` ymm; its kernel body measured through the
    ///   EVEX encoding, 4.2x the AVX2 f32 kernel): i8;
    /// - AVX2 without VNNI (`vpmaddwd` on u16 pairs; 1.1–1.6x, noisy): i8;
    /// - scalar on x86-64 (the f32 reference's `mul_add` is a libm call without FMA; i8 4x): i8;
    /// - NEON, and scalar elsewhere: f32 (the `sdot` and `smull` kernels are tested for equality
    ///   under emulation, their speed was not measured on aarch64 hardware).
    pub fn auto_for(isa: Isa) -> Self {
        if I8Kernel::for_isa(isa).faster_than_f32() {
            Self::I8
        } else {
            Self::F32
        }
    }

    /// Why this precision is slower than the other one on kernel path `isa`, naming the CPU
    /// feature that is missing; `None` when it is not known to be. Only [`Self::I8`] on NEON
    /// without the dot-product extension is: its `smull`/`sadalp` kernel issues as many
    /// multiply instructions as the f32 one, plus the widening adds. (Where `auto` picks f32 for
    /// want of a measurement, nothing is said.)
    pub fn slow_reason(self, isa: Isa) -> Option<String> {
        (self == Self::I8 && isa == Isa::Neon && isa.is_available() && !features().dotprod).then(|| {
            "svm = \"i8\" is not faster than \"f32\" here: this CPU lacks dotprod (the NEON smull/sadalp 8-bit \
             kernel issues as many multiplies as the f32 one); svm = \"auto\" picks f32"
                .to_string()
        })
    }

    /// Logs [`Self::slow_reason`] for this process's kernel path at `warn`, once per process.
    pub fn warn_if_slow(self) {
        if let Some(why) = self.slow_reason(crate::kernels::isa()) {
            if !WARNED_SLOW.swap(true, Ordering::Relaxed) {
                tracing::warn!(kernels = %crate::kernels::isa(), cpu = %features().names(), "{why}");
            }
        }
    }
}

impl std::fmt::Display for ScorePrecision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Errors of the scoring setup.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScoreError {
    /// A precision setting that is not one of [`PRECISION_SETTINGS`].
    #[error("unknown SVM precision {0:?}: allowed f32, i8, auto")]
    UnknownPrecision(String),
    /// A descriptor too long for exact i32 window sums on the 8-bit path.
    #[error("the 8-bit SVM path takes descriptors of at most {max} values (exact i32 sums), not {len}")]
    DescriptorTooLong {
        /// The model's descriptor length.
        len: usize,
        /// [`ScoreWeightsI8::MAX_DESCRIPTOR_LEN`].
        max: usize,
    },
    /// A window geometry whose weight matrix overflows `usize` or cannot be allocated.
    #[error("window geometry of {blocks_x}x{blocks_y} blocks of {block_len} values is too large for the SVM weights")]
    Geometry {
        /// Blocks per window across.
        blocks_x: usize,
        /// Blocks per window down.
        blocks_y: usize,
        /// Values per block.
        block_len: usize,
    },
}

impl FromStr for ScorePrecision {
    type Err = ScoreError;
    /// `f32`, `i8`, or `auto` ([`ScorePrecision::auto`]: resolved on this CPU now); ASCII case
    /// ignored.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Self::auto());
        }
        Self::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| ScoreError::UnknownPrecision(s.to_string()))
    }
}

/// The f32 block-product kernel of a path: every path has one ([`Isa::Scalar`] is the reference,
/// [`f32::mul_add`] chains); a path this CPU cannot run falls back to it.
fn f32_kernel(isa: Isa) -> Isa {
    if isa.is_available() {
        isa
    } else {
        Isa::Scalar
    }
}

/// The 8-bit block-product kernels (each with the quantiser of its instruction set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum I8Kernel {
    /// Plain i32 arithmetic: the reference.
    Scalar,
    /// AVX2 `vpmaddubsw` + `vpmaddwd` (no VNNI).
    Avx2Maddubs,
    /// AVX-VNNI `vpdpbusd` on ymm.
    AvxVnni,
    /// AVX-512 VNNI `vpdpbusd` on zmm.
    Avx512Vnni,
    /// The AVX-VNNI kernel's body with the EVEX encoding (AVX-512 VNNI + VL): tests only.
    #[cfg(test)]
    Vnni256,
    /// NEON `smull`/`sadalp`.
    NeonSmull,
    /// NEON `sdot` (dot-product extension).
    NeonSdot,
}

impl I8Kernel {
    /// The fastest 8-bit kernel of kernel path `isa` on this CPU (its sub-features from
    /// [`features`]); the scalar one for a path this CPU cannot run.
    pub(crate) fn for_isa(isa: Isa) -> Self {
        let f = features();
        if !isa.is_available() {
            return Self::Scalar;
        }
        match isa {
            Isa::Scalar => Self::Scalar,
            Isa::Avx512 if f.avx512vnni => Self::Avx512Vnni,
            Isa::Avx2 | Isa::Avx512 if f.avxvnni => Self::AvxVnni,
            Isa::Avx2 | Isa::Avx512 => Self::Avx2Maddubs,
            Isa::Neon if f.dotprod => Self::NeonSdot,
            Isa::Neon => Self::NeonSmull,
        }
    }

    /// Every 8-bit kernel path `isa` can run on this CPU (for the equality tests).
    #[cfg(test)]
    fn all_for(isa: Isa) -> Vec<Self> {
        let all = [
            Self::Scalar,
            Self::Avx2Maddubs,
            Self::AvxVnni,
            Self::Avx512Vnni,
            Self::Vnni256,
            Self::NeonSmull,
            Self::NeonSdot,
        ];
        all.into_iter()
            .filter(|k| k.isa() == isa && k.is_runnable())
            .collect()
    }

    /// The kernel path this kernel belongs to (its quantiser's instruction set).
    #[cfg(test)]
    fn isa(self) -> Isa {
        match self {
            Self::Scalar => Isa::Scalar,
            Self::Avx2Maddubs | Self::AvxVnni => Isa::Avx2,
            Self::Avx512Vnni | Self::Vnni256 => Isa::Avx512,
            Self::NeonSmull | Self::NeonSdot => Isa::Neon,
        }
    }

    /// This kernel if this CPU runs it, else the scalar reference.
    fn or_scalar(self) -> Self {
        if self.is_runnable() {
            self
        } else {
            Self::Scalar
        }
    }

    /// Whether this CPU has every feature the kernel uses.
    fn is_runnable(self) -> bool {
        let f = features();
        match self {
            Self::Scalar => true,
            Self::Avx2Maddubs => Isa::Avx2.is_available(),
            Self::AvxVnni => Isa::Avx2.is_available() && f.avxvnni,
            Self::Avx512Vnni => Isa::Avx512.is_available() && f.avx512vnni,
            #[cfg(test)]
            Self::Vnni256 => Isa::Avx512.is_available() && f.avx512vnni,
            Self::NeonSmull => Isa::Neon.is_available(),
            Self::NeonSdot => Isa::Neon.is_available() && f.dotprod,
        }
    }

    /// Whether this kernel was measured faster than the f32 kernel of its path (docs/detection.md,
    /// "8-bit SVM"; the rule of [`ScorePrecision::auto_for`]).
    fn faster_than_f32(self) -> bool {
        match self {
            Self::Scalar => cfg!(target_arch = "x86_64"),
            Self::Avx2Maddubs | Self::AvxVnni | Self::Avx512Vnni => true,
            #[cfg(test)]
            Self::Vnni256 => true,
            Self::NeonSmull | Self::NeonSdot => false,
        }
    }

    /// Column multiple the kernel steps by (a divisor of [`PAD_COLUMNS`]).
    fn lanes(self) -> usize {
        match self {
            Self::Scalar => 1,
            Self::NeonSmull => 4,
            Self::Avx512Vnni => 16,
            _ => 8,
        }
    }

    /// Block positions per tile (the kernel reads weights up to the tile's end).
    fn tile(self) -> usize {
        match self {
            Self::Scalar => 1,
            Self::Avx512Vnni => TILE_K_AVX512,
            _ => TILE_K_NARROW,
        }
    }
}

/// Largest quantised weight magnitude: `q = round(w·s)`, `s = 127 / max|w|`.
pub const WEIGHT_QUANT_MAX: f32 = 127.0;
/// The model quantised for the 8-bit path ([`ScorePrecision::I8`]): `wq[g·nkp + k]` packs the i8
/// weights of values `4g..4g+4` of block position `k` into one dword (little-endian, zero past
/// the block length), the layout `vpdpbusd` and `vpmaddubsw` broadcast, and `corr` the
/// per-position constant of the NEON kernels.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreWeightsI8 {
    wq: Vec<u32>,
    /// `corr[k] = 128·Σ_i q_w[i][k]`: what shifting the block values by −128 takes off a product.
    corr: Vec<i32>,
    bias: f32,
    /// `s = 127 / max|w|` (1 for an all-zero model).
    weight_scale: f32,
    /// `1 / (180·s)`: one unit of an i32 window sum in score units.
    unit: f32,
    /// Worst-case |score − exact score| (see [`Self::error_bound`]).
    error_bound: f32,
    /// Block length (36) and its dwords (`⌈bl/4⌉`).
    bl: usize,
    ng: usize,
    bw: usize,
    bh: usize,
    nk: usize,
    nkp: usize,
}

impl ScoreWeightsI8 {
    /// Longest descriptor whose window sums cannot overflow i32: `180 · 127 · n ≤ 2^31 − 1`
    /// (93 940; OpenCV's people detector has 3 780).
    pub const MAX_DESCRIPTOR_LEN: usize = i32::MAX as usize / (BLOCK_QUANT_SCALE as usize * 127);

    /// Quantise `w` (once per model): `q = round(w·s)`, `s = 127 / max|w|`; the bias stays f32.
    pub fn new(w: &ScoreWeights) -> Result<Self, ScoreError> {
        let (bl, nk, nkp) = (w.bl, w.nk, w.nkp);
        // nk·bl ≤ nkp·bl = w.wt.len(): no overflow.
        if nk * bl > Self::MAX_DESCRIPTOR_LEN {
            return Err(ScoreError::DescriptorTooLong {
                len: nk * bl,
                max: Self::MAX_DESCRIPTOR_LEN,
            });
        }
        let ng = bl.div_ceil(4);
        let weight = |i: usize, k: usize| w.wt[i * nkp + k];
        let all = || (0..nk).flat_map(move |k| (0..bl).map(move |i| weight(i, k)));
        let max = all().fold(0.0f32, |m, v| m.max(v.abs()));
        // An all-zero model scores its bias: any scale gives zero weights.
        let s = if max > 0.0 {
            WEIGHT_QUANT_MAX as f64 / max as f64
        } else {
            1.0
        };
        let q = |i: usize, k: usize| {
            if i < bl {
                (weight(i, k) as f64 * s).round().clamp(-127.0, 127.0) as i8
            } else {
                0
            }
        };
        let (mut wq, mut corr) = (vec![0u32; ng * nkp], vec![0i32; nkp]);
        for k in 0..nk {
            for g in 0..ng {
                let b: [u8; 4] = std::array::from_fn(|t| q(4 * g + t, k) as u8);
                wq[g * nkp + k] = u32::from_le_bytes(b);
            }
            corr[k] = 128 * (0..bl).map(|i| q(i, k) as i32).sum::<i32>();
        }
        // |Δ| ≤ Σ|w|·½/180 (values) + Σv·½/s (weights) + n·¼/(180·s) (both), with Σv ≤ nk·√bl
        // for blocks of L2 norm ≤ 1.
        let abs_sum: f64 = all().map(|v| v.abs() as f64).sum();
        let sum_v = nk as f64 * (bl as f64).sqrt();
        let qb = BLOCK_QUANT_SCALE as f64;
        let bound = abs_sum * 0.5 / qb + sum_v * 0.5 / s + (nk * bl) as f64 * 0.25 / (qb * s);
        Ok(Self {
            wq,
            corr,
            bias: w.bias,
            weight_scale: s as f32,
            unit: (1.0 / (qb * s)) as f32,
            error_bound: bound as f32,
            bl,
            ng,
            bw: w.bw,
            bh: w.bh,
            nk,
            nkp,
        })
    }

    /// The weight scale `s = 127 / max|w|`.
    pub fn weight_scale(&self) -> f32 {
        self.weight_scale
    }

    /// Worst-case difference between an 8-bit score and the exact score of the same blocks, for
    /// blocks of L2 norm ≤ 1 with values in [0, 1] (L2-Hys): `Σ|w|·½/180 + nk·√bl·½/s +
    /// n·¼/(180·s)` (the f32 conversion of the sum adds ≤ 1e-5 for realistic sums).
    pub fn error_bound(&self) -> f32 {
        self.error_bound
    }

    /// The quantised weight of value `i` of block position `k`.
    fn weight(&self, i: usize, k: usize) -> i8 {
        self.wq[(i / 4) * self.nkp + k].to_le_bytes()[i % 4] as i8
    }

    /// An exact i32 window sum to a score: `bias + sum·(1/(180·s))`, the same in every kernel.
    #[inline]
    fn score_from_sum(&self, sum: i32) -> f32 {
        self.bias + sum as f32 * self.unit
    }

    /// The 8-bit score of one window descriptor in OpenCV order (`spec.descriptor_len()` values):
    /// the same bits as [`window_scores_i8`] gives the window these blocks come from.
    pub fn score_descriptor(&self, d: &[f32]) -> f32 {
        let mut sum = 0i32;
        for k in 0..self.nk {
            let m = descriptor_position(k, self.bw, self.bh);
            for i in 0..self.bl {
                let v = d.get(m * self.bl + i).copied().unwrap_or(0.0);
                sum += quantise_block_value(v) as i32 * self.weight(i, k) as i32;
            }
        }
        self.score_from_sum(sum)
    }
}

/// Scores of every window of `grid` (row-major, `grid.windows()` wide) into `scores`, with the
/// kernel path of this process ([`crate::kernels::isa`]). `scores` must hold `nwx · nwy` values
/// (extra values are untouched).
pub fn window_scores(w: &ScoreWeights, grid: &BlockGrid, exec: Exec, scores: &mut [f32]) {
    window_scores_with(w, grid, exec, crate::kernels::isa(), scores)
}

/// [`window_scores`] on kernel path `isa` (a path this CPU cannot run falls back to the scalar
/// reference). Every path gives the same bits.
pub fn window_scores_with(w: &ScoreWeights, grid: &BlockGrid, exec: Exec, isa: Isa, scores: &mut [f32]) {
    let kernel = f32_kernel(isa);
    scores_by_strips(&F32Rows { w, kernel }, grid, exec, scores)
}

/// [`window_scores`] on the 8-bit path ([`ScorePrecision::I8`], see the module docs), with the
/// 8-bit kernel of this process's kernel path.
pub fn window_scores_i8(w: &ScoreWeightsI8, grid: &BlockGrid, exec: Exec, scores: &mut [f32]) {
    window_scores_i8_with(w, grid, exec, crate::kernels::isa(), scores)
}

/// [`window_scores_i8`] on kernel path `isa` (its fastest 8-bit kernel on this CPU; a path this
/// CPU cannot run falls back to the scalar reference). Every kernel gives the same bits.
pub fn window_scores_i8_with(w: &ScoreWeightsI8, grid: &BlockGrid, exec: Exec, isa: Isa, scores: &mut [f32]) {
    scores_i8_kernel(w, grid, exec, I8Kernel::for_isa(isa), scores)
}

/// [`window_scores_i8`] with one 8-bit kernel (the scalar one if this CPU cannot run it).
fn scores_i8_kernel(w: &ScoreWeightsI8, grid: &BlockGrid, exec: Exec, kernel: I8Kernel, scores: &mut [f32]) {
    let kernel = kernel.or_scalar();
    scores_by_strips(&I8Rows { w, kernel }, grid, exec, scores)
}

/// One precision's block-row products and final scores, for the strip driver [`scores_by_strips`].
trait RowProducts: Sync {
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
struct F32Rows<'a> {
    w: &'a ScoreWeights,
    kernel: Isa,
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
                super::kernels::avx2::add_window_row_f32(row, pr, by, bw, nbxp)
            },
            _ => add_window_row(row, pr, by, bw, nbxp),
        }
    }
}

/// The 8-bit path: quantised, dword-transposed block rows, exact i32 products and window sums.
#[derive(Clone, Copy)]
struct I8Rows<'a> {
    w: &'a ScoreWeightsI8,
    kernel: I8Kernel,
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
                super::kernels::avx2::add_window_row_i32(row, pr, by, bw, nbxp)
            },
            _ => add_window_row(row, pr, by, bw, nbxp),
        }
    }
}

/// The window sums of window rows `[first, first + rows)` of a grid `nbx` blocks wide, made from
/// its block rows `first, first + 1, …` as they are pushed: each row's products are computed once
/// into a small buffer and added to the window rows they belong to.
struct Stream<R: RowProducts> {
    r: R,
    nbx: usize,
    nbxp: usize,
    nwx: usize,
    first: usize,
    rows: usize,
    /// The index of the next block row.
    next: usize,
    scratch: R::Scratch,
    pr: Vec<R::Acc>,
    sums: Vec<R::Acc>,
}

impl<R: RowProducts> Stream<R> {
    /// Window rows `[first, first + rows)` of a grid `nbx` blocks wide (`nbx ≥ bw`).
    fn new(r: R, nbx: usize, first: usize, rows: usize) -> Self {
        Self::with_buffers(r, nbx, first, rows, Default::default())
    }

    /// [`Stream::new`] in the allocations `b` (whatever they hold).
    fn with_buffers(r: R, nbx: usize, first: usize, rows: usize, b: StreamBuffers<R>) -> Self {
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
    fn needed(&self) -> std::ops::Range<usize> {
        let bh = self.r.dims().2;
        self.first..self.first + self.rows + bh - 1
    }

    /// Add the next block row (`nbx` blocks).
    fn push(&mut self, row: &[f32]) {
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
    fn finish(&self, scores: &mut [f32]) {
        self.r.finish(&self.sums, scores);
    }

    /// Its allocations, for the next stream.
    fn into_buffers(self) -> StreamBuffers<R> {
        (self.scratch, self.pr, self.sums)
    }
}

/// The allocations of a [`Stream`]: scratch, products, window sums.
type StreamBuffers<R> = (
    <R as RowProducts>::Scratch,
    Vec<<R as RowProducts>::Acc>,
    Vec<<R as RowProducts>::Acc>,
);

/// Window scores of `grid` with one precision's products (see [`window_scores_with`]).
fn scores_by_strips<R: RowProducts + Copy>(r: &R, grid: &BlockGrid, exec: Exec, scores: &mut [f32]) {
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

/// Window scores of a block grid whose rows arrive one at a time, top to bottom (for example
/// from [`crate::features::hog::approx_block_rows`], which makes no grid): the same scores, bit
/// for bit, as [`window_scores`] / [`window_scores_i8`] of the whole grid, on one thread.
pub struct RowScorer<'w> {
    kind: RowScorerKind<'w>,
    nby: usize,
    pushed: usize,
}

enum RowScorerKind<'w> {
    /// Fewer blocks than a window: no scores.
    Empty,
    F32(Stream<F32Rows<'w>>),
    I8(Stream<I8Rows<'w>>),
}

/// The allocations of a [`RowScorer`] ([`RowScorer::into_buffers`]) for the next one: a caller
/// that scores many levels and frames keeps them instead of allocating (and zeroing) products
/// and window sums for each.
#[derive(Debug, Default)]
pub struct ScorerBuffers {
    f32: StreamBuffers<F32Rows<'static>>,
    i8: StreamBuffers<I8Rows<'static>>,
}

impl<'w> RowScorer<'w> {
    /// The f32 scores of an `nbx x nby`-block grid on kernel path `isa` ([`window_scores_with`]).
    pub fn f32(w: &'w ScoreWeights, isa: Isa, nbx: usize, nby: usize) -> Self {
        Self::f32_in(w, isa, nbx, nby, ScorerBuffers::default())
    }

    /// [`RowScorer::f32`] in the allocations of `b`.
    pub fn f32_in(w: &'w ScoreWeights, isa: Isa, nbx: usize, nby: usize, b: ScorerBuffers) -> Self {
        let r = F32Rows {
            w,
            kernel: f32_kernel(isa),
        };
        Self::with(r, nbx, nby, b.f32, RowScorerKind::F32)
    }

    /// The 8-bit scores of an `nbx x nby`-block grid on kernel path `isa`
    /// ([`window_scores_i8_with`]).
    pub fn i8(w: &'w ScoreWeightsI8, isa: Isa, nbx: usize, nby: usize) -> Self {
        Self::i8_in(w, isa, nbx, nby, ScorerBuffers::default())
    }

    /// [`RowScorer::i8`] in the allocations of `b`.
    pub fn i8_in(w: &'w ScoreWeightsI8, isa: Isa, nbx: usize, nby: usize, b: ScorerBuffers) -> Self {
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
    pub fn into_buffers(self) -> ScorerBuffers {
        let mut b = ScorerBuffers::default();
        match self.kind {
            RowScorerKind::Empty => {}
            RowScorerKind::F32(s) => b.f32 = s.into_buffers(),
            RowScorerKind::I8(s) => b.i8 = s.into_buffers(),
        }
        b
    }

    /// Windows across and down.
    pub fn windows(&self) -> (usize, usize) {
        match &self.kind {
            RowScorerKind::Empty => (0, 0),
            RowScorerKind::F32(s) => (s.nwx, s.rows),
            RowScorerKind::I8(s) => (s.nwx, s.rows),
        }
    }

    /// Add the grid's next block row (`nbx` blocks of the model's block length; panics on a
    /// shorter row or a row past the `nby`-th, like slicing).
    pub fn push(&mut self, row: &[f32]) {
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
    pub fn finish(&self, scores: &mut [f32]) {
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

/// `bt[i·nbxp + x] = row[x·bl + i]` for `x < nbx` (the padding columns stay zero).
fn transpose_row(row: &[f32], bl: usize, nbx: usize, nbxp: usize, bt: &mut [f32]) {
    for (x, blk) in row.chunks_exact(bl).take(nbx).enumerate() {
        for (i, &v) in blk.iter().enumerate() {
            bt[i * nbxp + x] = v;
        }
    }
}

/// The lengths every product kernel relies on, checked once per call (the kernels' `# Safety`
/// sections, for the slices [`position_slices`] hands them): `nbxp` whole vectors, `nbx ≤ nbxp`,
/// the transposed row `nd·nbxp`, the weights `nd` rows of `nkp` with the positions `ks` and the
/// rest of their last tile inside a row (`ks.start + round_up(ks.len(), tile) ≤ nkp`), the
/// products `ks.end·nbxp`.
#[allow(clippy::too_many_arguments)]
fn check_product_bounds(
    nbx: usize,
    nbxp: usize,
    nd: usize,
    bt_len: usize,
    ks: &Range<usize>,
    nkp: usize,
    w_len: usize,
    tile: usize,
    out_len: usize,
) {
    let fits = |a: usize, b: usize, len: usize| a.checked_mul(b).is_some_and(|n| n <= len);
    assert!(
        nbxp.is_multiple_of(PAD_COLUMNS)
            && nbx <= nbxp
            && ks.start <= ks.end
            && fits(nd, nbxp, bt_len)
            && fits(nd, nkp, w_len)
            && round_up(ks.len(), tile)
                .and_then(|t| t.checked_add(ks.start))
                .is_some_and(|t| t <= nkp)
            && fits(ks.end, nbxp, out_len),
        "block products out of bounds: {nbx}/{nbxp} columns, {nd} rows ({bt_len}), positions {ks:?} of {nkp} \
         (tile {tile}, weights {w_len}), products {out_len}"
    );
}

/// The weights (`nd` rows of `nkp`, `w`) and products (`out`) seen from position `ks.start`: a
/// kernel asked for `ks.len()` positions then computes exactly the positions `ks`.
fn position_slices<'a, W, T>(
    w: &'a [W],
    out: &'a mut [T],
    ks: &Range<usize>,
    nbxp: usize,
) -> (&'a [W], &'a mut [T]) {
    (&w[ks.start..], &mut out[ks.start * nbxp..])
}

/// `out[k·nbxp + x] = Σ_i bt[i·nbxp + x] · wt[i·nkp + k]` for `k ∈ ks`, `x < nbx` (SIMD kernels also
/// fill padding columns), fused multiply-adds in order `i = 0..bl` from 0.
fn block_products(
    w: &ScoreWeights,
    bt: &[f32],
    nbx: usize,
    nbxp: usize,
    ks: Range<usize>,
    kernel: Isa,
    out: &mut [f32],
) {
    let tile = match kernel {
        Isa::Avx512 => TILE_K_AVX512,
        _ => TILE_K_NARROW,
    };
    check_product_bounds(nbx, nbxp, w.bl, bt.len(), &ks, w.nkp, w.wt.len(), tile, out.len());
    let (bl, nk, nkp) = (w.bl, ks.len(), w.nkp);
    if nk == 0 {
        return;
    }
    let (wt, out) = position_slices(&w.wt, out, &ks, nbxp);
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `kernel` is a path this CPU runs (`f32_kernel`): AVX2 and FMA; lengths checked
        // above. Measured: see docs/detection.md "Speed" (SVM stage).
        Isa::Avx2 => unsafe { super::kernels::avx2::products_f32(bt, wt, bl, nk, nkp, nbxp, out) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, with AVX-512F.
        Isa::Avx512 => unsafe { super::kernels::avx512::products_f32(bt, wt, bl, nk, nkp, nbxp, out) },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 CPU; lengths checked above.
        Isa::Neon => unsafe { super::kernels::neon::products_f32(bt, wt, bl, nk, nkp, nbxp, out) },
        _ => block_products_scalar(w, bt, nbx, nbxp, ks, out),
    }
}

/// The scalar reference (`out` seen from position `ks.start`).
fn block_products_scalar(
    w: &ScoreWeights,
    bt: &[f32],
    nbx: usize,
    nbxp: usize,
    ks: Range<usize>,
    out: &mut [f32],
) {
    for (j, k) in ks.enumerate() {
        for x in 0..nbx {
            let mut acc = 0.0f32;
            for i in 0..w.bl {
                acc = bt[i * nbxp + x].mul_add(w.wt[i * w.nkp + k], acc);
            }
            out[j * nbxp + x] = acc;
        }
    }
}

/// Quantise block row `row` (`nbx` blocks of `bl` values) on the 8-bit path: `q[x·4ng + i]` =
/// [`quantise_block_value`] of value `i` of block `x` (zero for `bl ≤ i < 4ng`), then the dword
/// transpose: `btq[g·nbxp + x]` = bytes `4g..4g+4` of block `x`; padding columns stay zero.
/// For blocks of a multiple of 4 values (every HOG block) the kernel's instruction set
/// quantises; the bytes are the scalar ones.
fn quantise_row(
    row: &[f32],
    bl: usize,
    nbx: usize,
    nbxp: usize,
    kernel: I8Kernel,
    q: &mut [u8],
    btq: &mut [u32],
) {
    let ng = bl.div_ceil(4);
    let n = nbx * 4 * ng;
    // The bounds the SIMD quantisers rely on, once per call.
    assert!(
        row.len() >= nbx * bl
            && q.len() >= n
            && btq.len() >= ng * nbxp
            && nbxp.is_multiple_of(PAD_COLUMNS)
            && nbx <= nbxp,
        "quantise_row out of bounds: {nbx}/{nbxp} blocks of {bl}, row {}, q {}, btq {}",
        row.len(),
        q.len(),
        btq.len()
    );
    if bl == 4 * ng {
        match kernel {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the kernel is runnable (`scores_i8_kernel`), so the CPU has AVX-512F and
            // BW; lengths checked above with bl = 4·ng.
            I8Kernel::Avx512Vnni => {
                return unsafe { super::kernels::avx512::quantise_row_bytes(row, ng, nbx, nbxp, q, btq) };
            }
            #[cfg(target_arch = "x86_64")]
            // SAFETY: these kernels run only with AVX2 (`is_runnable`); n ≤ row.len(), q.len().
            I8Kernel::Avx2Maddubs | I8Kernel::AvxVnni => unsafe {
                super::kernels::avx2::quantise_values(row, n, q)
            },
            #[cfg(all(test, target_arch = "x86_64"))]
            // SAFETY: as above.
            I8Kernel::Vnni256 => unsafe { super::kernels::avx2::quantise_values(row, n, q) },
            #[cfg(target_arch = "aarch64")]
            // SAFETY: NEON is part of every aarch64 CPU; n ≤ row.len(), q.len().
            I8Kernel::NeonSmull | I8Kernel::NeonSdot => unsafe {
                super::kernels::neon::quantise_values(row, n, q)
            },
            _ => {
                for (d, &v) in q[..n].iter_mut().zip(&row[..n]) {
                    *d = quantise_block_value(v);
                }
            }
        }
    } else {
        for (dst, blk) in q.chunks_exact_mut(4 * ng).zip(row.chunks_exact(bl)).take(nbx) {
            for (d, &v) in dst.iter_mut().zip(blk) {
                *d = quantise_block_value(v);
            }
            dst[bl..].fill(0);
        }
    }
    for (x, blk) in q.chunks_exact(4 * ng).take(nbx).enumerate() {
        for (g, b) in blk.chunks_exact(4).enumerate() {
            btq[g * nbxp + x] = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
    }
}

/// `out[k·nbxp + x] = Σ_i q_b[i][x] · q_w[i][k]` for `k ∈ ks`, `x < nbx` (SIMD kernels also fill
/// padding columns), exact in i32.
fn quant_products(
    w: &ScoreWeightsI8,
    btq: &[u32],
    nbx: usize,
    nbxp: usize,
    ks: Range<usize>,
    kernel: I8Kernel,
    out: &mut [i32],
) {
    let nd = w.ng;
    check_product_bounds(
        nbx,
        nbxp,
        nd,
        btq.len(),
        &ks,
        w.nkp,
        w.wq.len(),
        kernel.tile(),
        out.len(),
    );
    debug_assert!(PAD_COLUMNS.is_multiple_of(kernel.lanes()));
    let (nk, nkp) = (ks.len(), w.nkp);
    if nk == 0 {
        return;
    }
    #[cfg(target_arch = "aarch64")]
    // corr holds nkp values, so ks.start.. holds the positions the kernel reads (checked above).
    let corr = &w.corr[ks.start..];
    let (wq, out) = position_slices(&w.wq, out, &ks, nbxp);
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the kernel is runnable (`scores_i8_kernel`): AVX-512F, BW and VNNI; lengths
        // checked above. Measured: see docs/detection.md "8-bit SVM".
        I8Kernel::Avx512Vnni => unsafe {
            super::kernels::avx512::products_bytes_vnni(btq, wq, nd, nk, nkp, nbxp, out)
        },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: runnable: AVX2 and AVX-VNNI; lengths checked above.
        I8Kernel::AvxVnni => unsafe {
            super::kernels::avx2::products_bytes_avxvnni(btq, wq, nd, nk, nkp, nbxp, out)
        },
        #[cfg(all(test, target_arch = "x86_64"))]
        // SAFETY: runnable: AVX2, AVX-512 VNNI (and VL, part of the AVX-512 path); lengths checked.
        I8Kernel::Vnni256 => unsafe {
            super::kernels::avx2::products_bytes_vnni256(btq, wq, nd, nk, nkp, nbxp, out)
        },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: runnable: AVX2; lengths checked above. Exact for the L2-normalised blocks of
        // every BlockGrid (the kernel's module docs).
        I8Kernel::Avx2Maddubs => unsafe {
            super::kernels::avx2::products_bytes_maddubs(btq, wq, nd, nk, nkp, nbxp, out)
        },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: runnable: the dot-product extension; lengths checked above, corr holds nkp ≥ nk.
        I8Kernel::NeonSdot => unsafe {
            super::kernels::neon::products_bytes_sdot(btq, wq, corr, nd, nk, nkp, nbxp, out)
        },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 CPU; lengths checked above, corr holds nkp ≥ nk.
        I8Kernel::NeonSmull => unsafe {
            super::kernels::neon::products_bytes_smull(btq, wq, corr, nd, nk, nkp, nbxp, out)
        },
        _ => quant_products_scalar(w, btq, nbx, nbxp, ks, out),
    }
}

/// The scalar reference of the 8-bit path: plain i32 arithmetic over the byte layout (`out` seen
/// from position `ks.start`).
fn quant_products_scalar(
    w: &ScoreWeightsI8,
    btq: &[u32],
    nbx: usize,
    nbxp: usize,
    ks: Range<usize>,
    out: &mut [i32],
) {
    for (j, k) in ks.enumerate() {
        for x in 0..nbx {
            let mut acc = 0i32;
            for g in 0..w.ng {
                let b = btq[g * nbxp + x].to_le_bytes();
                let q = w.wq[g * w.nkp + k].to_le_bytes();
                for t in 0..4 {
                    acc += b[t] as i32 * q[t] as i8 as i32;
                }
            }
            out[j * nbxp + x] = acc;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::hog::{block_grid, HogInput, HogOptions};
    use crate::image::Image;

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
