//! Approximate HOG block grids of other scales from one exactly computed level: the
//! feature-pyramid approximation of Dollár, Appel, Belongie & Perona (2014), done on
//! orientation channels *before* they are spatially pooled.
//!
//! # Method
//!
//! An exact level `L` (`W x H` pixels, gamma-corrected) is pooled once into a [`MicroGrid`]:
//! `m x m`-pixel micro-cells (the detector uses `m` = [`MICRO_CELL`] = 2), each holding the sum
//! of its pixels' orientation votes per bin (the same two interpolated votes `|g|(1−f)`, `|g|f` as the
//! exact cells, no spatial weight). For a level `L'` of `W' x H'` pixels, `r_x = W'/W`,
//! `r_y = H'/H`, a micro-cell whose centre is the pixel coordinate `(u, v)` of `L` stands at
//! `(u', v') = ((u+½)·r_x − ½, (v+½)·r_y − ½)` in `L'` (the half-pixel convention of the pyramid's
//! bilinear resize, so `L'` pixel centres and the mapped micro-cells agree). It then votes into the
//! cell of `L'` that contains `(u', v')` exactly as a pixel at that point would: with the cell's
//! 4 x-profiles and 4 y-profiles (OpenCV's Gaussian block window times the bilinear weight of the
//! block's cell centres, see the parent module) evaluated at the *continuous* offset in the cell,
//! times a gain `√(r_x r_y)`. Blocks are assembled from those cells and L2-Hys-normalised as for
//! an exact level.
//!
//! The gain: gradient magnitudes summed over an area measure the length of the edges in it (a
//! `[−1, 0, 1]` step response integrates to the same value at any scale), and lengths shrink by
//! `r` from `L` to `L'`, so an `L'` cell holds about `r` times what the micro-cells mapped into it
//! hold. L2-Hys removes any global factor but for its first epsilon (`0.1·36` added to the block
//! norm), so the gain only matters for faint blocks.
//!
//! # Where we differ
//!
//! - Dollár et al. resample per-pixel channels and pool them afterwards at the coarse scale with
//!   a box filter, and correct magnitudes with a fitted power law `r^−λ`. We keep OpenCV's pooling
//!   (Gaussian-windowed, bilinear over cell centres) by evaluating its weights at the mapped
//!   micro-cell positions, and use the edge-length gain `r` (no fitted λ; on USC, gain `1`
//!   instead of `r` gave the same AP within noise, 0.646 vs 0.643 at `--approx 14`).
//! - Levels are only approximated downwards (from the finer exact level): approximating a level
//!   from the next *coarser* exact level gave larger window-score errors at every distance but
//!   the last two levels of a group of 14.
//! - Micro-cells are placed at their centre: a vote's position inside its micro-cell is lost
//!   (at `m` = 2, ≤ ½ pixel), which is why `m` = 4 loses more than `m` = 2.
//! - Gradients (and their orientations) are those of `L`, not of the coarser `L'`: texture finer
//!   than `L'` resolves keeps its votes. That is the approximation's residual error.
//! - The previous approximation (until commit 07aa828) resampled the *pooled* 8x8 cells
//!   bilinearly, which mixes neighbouring cells' Gaussian-weighted histograms and lost ≈ 6 AP
//!   points on USC at any spacing of exact levels; this one is within ≈ 0.5 (docs/detection.md).
//! - Micro-cells are **stored as IEEE half floats** (summed in `f32` per micro row, then rounded
//!   to nearest even, [`f16_bits`]; read back exactly). Every approximated level reads the whole
//!   micro grid of its exact level, and that read is what the stage waits on: padding micro-cells
//!   to 16 floats made it slower, half floats made it 12–22 % faster (docs/detection.md). Votes are
//!   below ≈ 130 (gamma-corrected 8-bit units, 4 pixels), so the relative error is ≤ 2⁻¹¹; on the
//!   1080p bench frame window scores moved by at most 5.4e-4 (mean 7.9e-5), no box changed, and
//!   USC AP is the same at all seven pyramid phases we measure. The exact pyramid is untouched.
//! - At `r = 1` and `m = 1` this is the exact grid up to summation order and half-float rounding
//!   (tested).
//! - The AVX-512 fill builds a level one **cell at a time in registers** (its 16 profile
//!   histograms stay in 16 registers while the micro rows and micro-cells landing in it are
//!   added), skipping the x-profile that is exactly zero on each half of a cell. The portable fill
//!   goes a micro row at a time through row buffers. Both make the same fused multiply-adds
//!   ([`f32::mul_add`]; FMA instructions where the CPU has them) in the same order, so the same
//!   bits (tested). The register fill took the approximated levels from ≈ 50 to ≈ 32 ms of CPU per
//!   1080p frame and fused multiply-adds (instead of a multiply, then an add) to ≈ 27; those
//!   moved window scores by ≤ 2.9e-6 (docs/detection.md).

use rayon::prelude::*;

use super::{
    blocks_in_bands_with, cell_len, cell_slot, gradient_row, have_avx2, live_profiles, planes_of, BlockGrid,
    CellKernel, CellScratch, Exec, GammaPlanes, HogError, HogSpec, Planes, RowScratch, BAND_BLOCK_ROWS,
    BLOCK_CELLS, CELL_SIZE, PROFILES,
};

/// Micro-cell side the detector uses, in pixels. Dollár et al. shrink channels by 4; on USC
/// (docs/detection.md) 4 costs ≈ 1 AP point more than 2 at `--approx 14` for ≈ 20 % less time,
/// 1 gains nothing over 2.
pub const MICRO_CELL: usize = 2;
/// Micro-cell rows per parallel task.
const MICRO_ROWS_PER_TASK: usize = 4;

/// Orientation histograms of `m x m`-pixel micro-cells of one level (no spatial weights): the
/// source of [`blocks_from_micro_grid`]. Pixels beyond the last whole micro-cell are left out.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MicroGrid {
    nmx: usize,
    nmy: usize,
    size: usize,
    width: usize,
    height: usize,
    nbins: usize,
    /// Votes as IEEE half-precision bits ([`f16_bits`]), `[my][mx][bin]`.
    data: Vec<u16>,
}

impl MicroGrid {
    /// Shape for `size`-pixel micro-cells of `p` (buffer reused, contents stale).
    fn reshape(&mut self, p: &Planes, size: usize, nb: usize) {
        let (nmx, nmy) = (p.width / size, p.height / size);
        *self = MicroGrid {
            nmx,
            nmy,
            size,
            width: p.width,
            height: p.height,
            nbins: nb,
            data: std::mem::take(&mut self.data),
        };
        self.data.resize(nmx * nmy * nb, 0);
    }

    /// An empty grid (fill with [`micro_grid_from_gamma_planes`]).
    pub fn empty() -> Self {
        Self::default()
    }
    /// Micro-cells across.
    pub fn cells_x(&self) -> usize {
        self.nmx
    }
    /// Micro-cells down.
    pub fn cells_y(&self) -> usize {
        self.nmy
    }
    /// Micro-cell side in pixels.
    pub fn cell_size(&self) -> usize {
        self.size
    }
    /// Width of the level the grid was pooled from, in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height of that level.
    pub fn height(&self) -> usize {
        self.height
    }
    /// The `nbins` votes of micro-cell (mx, my) (stored as half floats, returned exactly).
    pub fn cell(&self, mx: usize, my: usize) -> Vec<f32> {
        self.data[(my * self.nmx + mx) * self.nbins..][..self.nbins]
            .iter()
            .map(|&h| f32_from_f16(h))
            .collect()
    }
}

/// Pool gamma-corrected planes into `size x size`-pixel micro-cells (`size` in 1..=8): the same
/// gradients and orientation votes as the exact cells, summed per micro-cell and bin. `dst`'s
/// buffer is reused. Errors as [`super::cell_grid_from_gamma_planes`], plus
/// [`HogError::BadMicroCell`].
pub fn micro_grid_from_gamma_planes(
    spec: &HogSpec,
    planes: &GammaPlanes,
    size: usize,
    exec: Exec,
    dst: &mut MicroGrid,
) -> Result<(), HogError> {
    if !(1..=CELL_SIZE).contains(&size) {
        return Err(HogError::BadMicroCell(size));
    }
    let p = planes_of(spec, planes)?;
    let nb = spec.nbins();
    dst.reshape(&p, size, nb);
    let row_len = dst.nmx * nb;
    if row_len == 0 {
        return Ok(());
    }
    let avx2 = have_avx2();
    let work =
        |(t, chunk): (usize, &mut [u16])| micro_rows_with(avx2, &p, nb, size, t * MICRO_ROWS_PER_TASK, chunk);
    let task = MICRO_ROWS_PER_TASK * row_len;
    match exec {
        Exec::Parallel => dst.data.par_chunks_mut(task).enumerate().for_each(work),
        Exec::Serial => dst.data.chunks_mut(task).enumerate().for_each(work),
    }
    Ok(())
}

/// [`super::block_grid_from_gamma_planes`] and [`micro_grid_from_gamma_planes`] of the same
/// planes at once, with the same results bit for bit. With the AVX-512 cell kernel and `size` 2,
/// the micro-cells are pooled inside the cell pass from the gradients it computes anyway
/// (`cells_micro_row_avx512`), instead of a second pass that computes every gradient again;
/// otherwise this runs the two functions one after the other. Errors as theirs.
pub fn block_and_micro_grids_from_gamma_planes(
    spec: &HogSpec,
    planes: &GammaPlanes,
    size: usize,
    exec: Exec,
    blocks: &mut BlockGrid,
    micro: &mut MicroGrid,
) -> Result<(), HogError> {
    let kernel = CellKernel::detect(spec);
    let p = planes_of(spec, planes)?;
    let (ncx, ncy) = (p.width / CELL_SIZE, p.height / CELL_SIZE);
    if size != 2 || kernel != CellKernel::Avx512 || ncx < BLOCK_CELLS || ncy < BLOCK_CELLS {
        super::block_grid_from_gamma_planes(spec, planes, exec, blocks)?;
        return micro_grid_from_gamma_planes(spec, planes, size, exec, micro);
    }
    #[cfg(target_arch = "x86_64")]
    {
        let nb = spec.nbins();
        micro.reshape(&p, size, nb);
        // Micro rows per cell row, and the length of one micro row.
        let per_cell = CELL_SIZE / size;
        let row_len = micro.nmx * nb;
        // Band b fills cell rows 16b ..= 16b + 16; it pools the micro rows of the first 16 (the
        // last band: of all it fills), so every micro row is written once.
        let nbands = (ncy - 1).div_ceil(BAND_BLOCK_ROWS);
        let (mut rest, tail) = micro.data.split_at_mut(ncy * per_cell * row_len);
        let mut slots = Vec::with_capacity(nbands);
        for b in 0..nbands {
            let rows = if b + 1 == nbands {
                ncy - b * BAND_BLOCK_ROWS
            } else {
                BAND_BLOCK_ROWS
            };
            let (own, r) = rest.split_at_mut(rows * per_cell * row_len);
            slots.push(std::sync::Mutex::new(Some(own)));
            rest = r;
        }
        let scratch = |b: usize| {
            let own = slots[b]
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .take()
                .expect("each band takes its own micro rows once");
            (CellScratch::new(p.width), own, b * BAND_BLOCK_ROWS)
        };
        let fill = |cy: usize, row: &mut [f32], s: &mut (CellScratch, &mut [u16], usize)| {
            let (cs, own, first) = s;
            let at = (cy - *first) * per_cell * row_len;
            if at < own.len() {
                let m = &mut own[at..][..per_cell * row_len];
                // SAFETY: `CellKernel::detect` chose the AVX-512 kernel, so AVX-512F/BW/VL, AVX2
                // and FMA are present, nbins ≤ 16 and the profiles have their fixed zeros; `row`
                // is one cell row and `m` its micro rows.
                unsafe { super::cells_micro_row_avx512(spec, &p, cy, row, cs, m) }
            } else {
                super::cells_strip_with(kernel, spec, &p, cy, row, cs)
            }
        };
        super::blocks_in_bands_with(spec, ncx, ncy, exec, have_avx2(), blocks, scratch, fill);
        // Micro rows below the last whole cell row.
        micro_rows_with(have_avx2(), &p, nb, size, ncy * per_cell, tail);
    }
    Ok(())
}

/// [`micro_rows`], the AVX2 + FMA build when `avx2` (which must then be supported).
fn micro_rows_with(avx2: bool, p: &Planes, nb: usize, size: usize, my0: usize, chunk: &mut [u16]) {
    avx2_or_generic!(
        avx2,
        micro_rows_avx2(p, nb, size, my0, chunk),
        micro_rows(p, nb, size, my0, chunk)
    )
}

/// [`micro_rows`] compiled for AVX2 + FMA (vectorises the gradient pass).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn micro_rows_avx2(p: &Planes, nb: usize, size: usize, my0: usize, chunk: &mut [u16]) {
    micro_rows(p, nb, size, my0, chunk)
}

/// Micro-cell rows from `my0` on (as many as `chunk` holds, every value written): each row summed
/// in `f32`, then stored as half floats.
#[inline(always)]
fn micro_rows(p: &Planes, nb: usize, size: usize, my0: usize, chunk: &mut [u16]) {
    let nmx = p.width / size;
    let used = nmx * size;
    let mut sc = RowScratch::new(p.width);
    let mut bins = vec![[0u8; 2]; used];
    let mut wts = vec![[0.0f32; 2]; used];
    let mut row = vec![0.0f32; nmx * nb];
    for (k, out) in chunk.chunks_mut(nmx * nb).enumerate() {
        let my = my0 + k;
        row.fill(0.0);
        for y in my * size..(my + 1) * size {
            gradient_row(p, y, nb, &mut sc, &mut bins, &mut wts);
            for (cell, (b, w)) in row
                .chunks_exact_mut(nb)
                .zip(bins.chunks_exact(size).zip(wts.chunks_exact(size)))
            {
                for (&[b0, b1], &[w0, w1]) in b.iter().zip(w) {
                    cell[b0 as usize] += w0;
                    cell[b1 as usize] += w1;
                }
            }
        }
        to_f16_row(&row, out);
    }
}

/// `out[i] = f16_bits(src[i])`, with F16C's conversion (the same rounding) where the CPU has it.
fn to_f16_row(src: &[f32], out: &mut [u16]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("f16c") {
        // SAFETY: F16C detected.
        return unsafe { to_f16_row_f16c(src, out) };
    }
    for (o, &v) in out.iter_mut().zip(src) {
        *o = f16_bits(v);
    }
}

/// [`to_f16_row`] with `vcvtps2ph` (round to nearest even, as [`f16_bits`]), 8 values at a time.
///
/// # Safety
/// The CPU must support F16C.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "f16c,avx")]
unsafe fn to_f16_row_f16c(src: &[f32], out: &mut [u16]) {
    use std::arch::x86_64::*;
    let n = src.len().min(out.len());
    let mut i = 0;
    while i + 8 <= n {
        // SAFETY: 8 values at i < n in both slices.
        unsafe {
            let v = _mm256_loadu_ps(src.as_ptr().add(i));
            let h = _mm256_cvtps_ph::<_MM_FROUND_TO_NEAREST_INT>(v);
            _mm_storeu_si128(out.as_mut_ptr().add(i) as *mut __m128i, h);
        }
        i += 8;
    }
    for j in i..n {
        out[j] = f16_bits(src[j]);
    }
}

/// `out[i] = f32_from_f16(src[i])` (exact), with F16C's conversion where the CPU has it.
fn from_f16_row(src: &[u16], out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("f16c") {
        // SAFETY: F16C detected.
        return unsafe { from_f16_row_f16c(src, out) };
    }
    for (o, &h) in out.iter_mut().zip(src) {
        *o = f32_from_f16(h);
    }
}

/// [`from_f16_row`] with `vcvtph2ps`, 8 values at a time.
///
/// # Safety
/// The CPU must support F16C.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "f16c,avx")]
unsafe fn from_f16_row_f16c(src: &[u16], out: &mut [f32]) {
    use std::arch::x86_64::*;
    let n = src.len().min(out.len());
    let mut i = 0;
    while i + 8 <= n {
        // SAFETY: 8 values at i < n in both slices.
        unsafe {
            let h = _mm_loadu_si128(src.as_ptr().add(i) as *const __m128i);
            _mm256_storeu_ps(out.as_mut_ptr().add(i), _mm256_cvtph_ps(h));
        }
        i += 8;
    }
    for j in i..n {
        out[j] = f32_from_f16(src[j]);
    }
}

/// IEEE 754 half-precision bits of `x`, rounded to nearest, ties to even (overflow to infinity,
/// underflow through the subnormals to zero; a NaN stays a quiet NaN).
pub fn f16_bits(x: f32) -> u16 {
    let b = x.to_bits();
    let sign = ((b >> 16) & 0x8000) as u16;
    let exp = ((b >> 23) & 0xff) as i32;
    let man = b & 0x7f_ffff;
    if exp == 0xff {
        return sign | 0x7c00 | if man != 0 { 0x200 | (man >> 13) as u16 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 0x1f {
        return sign | 0x7c00;
    }
    let round = |r: u32, rem: u32, half: u32| r + u32::from(rem > half || (rem == half && r & 1 == 1));
    if e <= 0 {
        if e < -10 {
            return sign;
        }
        let m = man | 0x80_0000;
        let shift = (14 - e) as u32;
        let r = round(m >> shift, m & ((1 << shift) - 1), 1 << (shift - 1));
        return sign | r as u16;
    }
    // A carry out of the mantissa moves into the exponent, which is the correct result (up to
    // infinity).
    let r = round(((e as u32) << 10) | (man >> 13), man & 0x1fff, 0x1000);
    sign | r as u16
}

/// The `f32` value of half-precision bits `h` (exact; a NaN keeps its payload and comes back
/// quiet).
pub fn f32_from_f16(h: u16) -> f32 {
    let sign = u32::from(h & 0x8000) << 16;
    let exp = u32::from((h >> 10) & 0x1f);
    let man = u32::from(h & 0x3ff);
    let bits = match (exp, man) {
        (0, 0) => sign,
        (0, _) => {
            // Subnormal: normalise (2^-14 has f32 exponent 113).
            let shift = man.leading_zeros() - 21;
            sign | ((113 - shift) << 23) | (((man << shift) & 0x3ff) << 13)
        }
        (0x1f, 0) => sign | 0x7f80_0000,
        // A NaN comes back quiet, as F16C converts it.
        (0x1f, _) => sign | 0x7fc0_0000 | (man << 13),
        _ => sign | ((exp + 112) << 23) | (man << 13),
    };
    f32::from_bits(bits)
}

/// Where one micro-cell row or column lands in the target level: its cell and the weights of the
/// 4 profiles at its continuous offset in that cell.
#[derive(Debug, Clone, Copy, PartialEq)]
struct AxisTap {
    cell: usize,
    w: [f32; PROFILES],
}

/// Profile `p` (block cell · 2 + offset of the image cell in the block) at the continuous pixel
/// offset `k ∈ [−½, 8−½)` in the cell: OpenCV's Gaussian window times the bilinear (tent) weight
/// of the block cell's centre, zero outside the block. At integer `k` it is [`HogSpec`]'s
/// discrete profile.
fn profile_at(spec: &HogSpec, p: usize, k: f32) -> f32 {
    let (bc, off) = (p / BLOCK_CELLS, p % BLOCK_CELLS);
    let j = (off * CELL_SIZE) as f32 + k;
    let sigma = spec.win_sigma();
    let scale = 1.0 / (sigma * sigma * 2.0);
    let d = j - (BLOCK_CELLS * CELL_SIZE) as f32 * 0.5;
    let g = (-(d * d) * scale).exp();
    let cell = (j + 0.5) / CELL_SIZE as f32 - 0.5;
    g * (1.0 - (cell - bc as f32).abs()).max(0.0)
}

/// Taps of `n` micro-cells of `size` pixels along one axis into `cells` cells of a level `ratio`
/// times as large; `None` for micro-cells that land outside the cells.
fn axis_taps(spec: &HogSpec, n: usize, size: usize, ratio: f64, cells: usize) -> Vec<Option<AxisTap>> {
    (0..n)
        .map(|i| {
            let centre = (i * size) as f64 + (size as f64 - 1.0) * 0.5;
            let u = (centre + 0.5) * ratio - 0.5;
            let c = ((u + 0.5) / CELL_SIZE as f64).floor();
            if c < 0.0 || c >= cells as f64 {
                return None;
            }
            let k = (u - c * CELL_SIZE as f64) as f32;
            Some(AxisTap {
                cell: c as usize,
                w: std::array::from_fn(|p| profile_at(spec, p, k)),
            })
        })
        .collect()
}

/// The normalised block grid of a `width x height` level approximated from `micro` (pooled from
/// another level of the same image), with cell values times `gain` (see the module docs; the
/// detector passes `√(r_x r_y)`). Bands of block rows run in parallel as in
/// [`super::block_grid_from_gamma_planes`]; the result does not depend on the thread count.
/// `dst`'s buffer is reused.
pub fn blocks_from_micro_grid(
    spec: &HogSpec,
    micro: &MicroGrid,
    width: usize,
    height: usize,
    gain: f32,
    exec: Exec,
    dst: &mut BlockGrid,
) {
    let (ncx, ncy) = (width / CELL_SIZE, height / CELL_SIZE);
    let nb = spec.nbins();
    if micro.nmx == 0 || micro.nmy == 0 || ncx == 0 || ncy == 0 {
        super::block_grid_shape(spec, 0, 0, dst);
        return;
    }
    debug_assert_eq!(micro.nbins, nb);
    let taps = Taps::new(spec, micro, width, height, gain);
    let kernel = FillKernel::detect();
    let scratch = |_| FillScratch::new();
    let fill = |cy: usize, row: &mut [f32], s: &mut FillScratch| fill_with(kernel, micro, &taps, cy, row, s);
    blocks_in_bands_with(spec, ncx, ncy, exec, have_avx2(), dst, scratch, fill);
}

/// The micro rows (or columns) `[lo, hi)` landing in each of `ncy` cell rows (columns)
/// (contiguous, since the mapping is monotonic).
fn row_ranges(yt: &[Option<AxisTap>], ncy: usize) -> Vec<(usize, usize)> {
    let mut rows = vec![(0usize, 0usize); ncy];
    for (my, t) in yt.iter().enumerate() {
        if let Some(t) = t {
            let r = &mut rows[t.cell];
            if r.1 == r.0 {
                *r = (my, my + 1);
            } else {
                r.1 = my + 1;
            }
        }
    }
    rows
}

/// The taps of one approximated level.
struct Taps {
    xt: Vec<Option<AxisTap>>,
    yt: Vec<Option<AxisTap>>,
    /// Micro rows `[lo, hi)` landing in each cell row.
    rows: Vec<(usize, usize)>,
    /// Micro columns `[lo, hi)` landing in each cell column.
    cols: Vec<(usize, usize)>,
    /// The x-profile weights of each micro column (zeros where it has no tap).
    xw: Vec<[f32; PROFILES]>,
    /// Per cell column, the micro column `mid` such that only [`LEFT_PROFILES`] can be non-zero
    /// on `[lo, mid)` and only [`RIGHT_PROFILES`] on `[mid, hi)` (always so for [`HogSpec`]'s
    /// profiles: the tent of a block's second cell starts at a cell's centre); `None` if not.
    split: Vec<Option<usize>>,
    ncx: usize,
    gain: f32,
}

impl Taps {
    /// The taps of the `width x height` level approximated from `micro`, cell values times `gain`.
    fn new(spec: &HogSpec, micro: &MicroGrid, width: usize, height: usize, gain: f32) -> Self {
        let (ncx, ncy) = (width / CELL_SIZE, height / CELL_SIZE);
        let rx = width as f64 / micro.width as f64;
        let ry = height as f64 / micro.height as f64;
        let xt = axis_taps(spec, micro.nmx, micro.size, rx, ncx);
        let yt = axis_taps(spec, micro.nmy, micro.size, ry, ncy);
        let rows = row_ranges(&yt, ncy);
        let cols = row_ranges(&xt, ncx);
        let xw: Vec<[f32; PROFILES]> = xt.iter().map(|t| t.map_or([0.0; PROFILES], |t| t.w)).collect();
        // The profile each half of a cell leaves out (2 on the left, 1 on the right).
        let off = |live: [usize; 3]| (0..PROFILES).find(|p| !live.contains(p)).expect("3 of 4 live");
        let (off_left, off_right) = (off(LEFT_PROFILES), off(RIGHT_PROFILES));
        let split = cols
            .iter()
            .map(|&(lo, hi)| {
                let mid = (lo..hi).find(|&mx| xw[mx][off_left] != 0.0).unwrap_or(hi);
                let ok = (lo..mid).all(|mx| xw[mx][off_left] == 0.0)
                    && (mid..hi).all(|mx| xw[mx][off_right] == 0.0);
                ok.then_some(mid)
            })
            .collect();
        Self {
            xt,
            yt,
            rows,
            cols,
            xw,
            split,
            ncx,
            gain,
        }
    }
}

/// The x-profiles that can be non-zero in the left / right half of a cell ([`live_profiles`] of
/// the exact cell kernel): the register fill multiplies only these.
const LEFT_PROFILES: [usize; 3] = live_profiles(0);
const RIGHT_PROFILES: [usize; 3] = live_profiles(CELL_SIZE / 2);

/// Per-band buffers of [`fill_cell_row`].
struct FillScratch {
    /// One micro row pooled horizontally: `[cell][x-profile][bin]`.
    h: Vec<f32>,
    /// The cell row being built: `[y-profile][cell][x-profile][bin]`.
    t: Vec<f32>,
    /// The micro row being pooled, as `f32` (kernels that cannot read half floats directly).
    v: Vec<f32>,
}

impl FillScratch {
    /// Empty buffers; the portable fill sizes them on first use (the AVX-512 fill needs none).
    fn new() -> Self {
        Self {
            h: Vec::new(),
            t: Vec::new(),
            v: Vec::new(),
        }
    }
}

/// Which build of [`fill_cell_row`] runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum FillKernel {
    Generic,
    Avx2,
    Avx512,
}

impl FillKernel {
    fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        if have_avx2() {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512bw")
                && std::arch::is_x86_feature_detected!("avx512vl")
                && std::arch::is_x86_feature_detected!("f16c")
            {
                return Self::Avx512;
            }
            return Self::Avx2;
        }
        Self::Generic
    }
}

/// [`fill_cell_row`] with `kernel` (the same fused multiply-adds in the same order: the same bits).
fn fill_with(
    kernel: FillKernel,
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
    s: &mut FillScratch,
) {
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `FillKernel::detect` saw AVX2 and FMA.
        FillKernel::Avx2 => unsafe { fill_cell_row_avx2(micro, taps, cy, row, s) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `FillKernel::detect` saw AVX-512F/BW/VL, F16C, AVX2 and FMA.
        FillKernel::Avx512 => unsafe { fill_cell_row_avx512(micro, taps, cy, row, s) },
        _ => fill_cell_row(micro, taps, cy, row, s, hpass),
    }
}

/// [`fill_cell_row`] compiled for AVX2 + FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn fill_cell_row_avx2(
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
    s: &mut FillScratch,
) {
    fill_cell_row(micro, taps, cy, row, s, hpass)
}

/// [`fill_cell_row`] compiled for AVX-512F.
///
/// # Safety
/// The CPU must support AVX-512F/BW/VL, F16C, AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,f16c,avx2,fma")]
unsafe fn fill_cell_row_avx512(
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
    s: &mut FillScratch,
) {
    if micro.nbins <= 16 {
        // SAFETY: this function's target features; nbins ≤ 16 checked; `row` is one cell row.
        unsafe { fill_cell_row_regs_avx512(micro.nbins, micro, taps, cy, row) }
    } else {
        fill_cell_row(micro, taps, cy, row, s, hpass)
    }
}

/// [`fill_cell_row`] one cell at a time, everything in registers: for each micro row landing in
/// cell row `cy` (in order), the cell's run of micro-cells is summed into four 16-lane registers
/// (one per x-profile, bins in lanes), and those are added with the row's four y-profile weights
/// (times the gain) into the cell's 16 profile histograms, which stay in registers until the cell
/// is stored into its slots. The same fused multiply-adds in the same order as
/// [`fill_cell_row`] with [`hpass`] (every value is a chain over micro rows, each term a chain
/// over micro-cells from `+0`), so the same bits; but no `[y-profile][cell][x-profile][bin]` row
/// buffer goes through L2 per micro row, and no permutation pass follows.
///
/// # Safety
/// The CPU must support AVX-512F/BW/VL and F16C; `nb ≤ 16`; `row` holds `taps.ncx` cells.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,f16c,avx2,fma")]
unsafe fn fill_cell_row_regs_avx512(nb: usize, micro: &MicroGrid, taps: &Taps, cy: usize, row: &mut [f32]) {
    use std::arch::x86_64::*;
    debug_assert!(nb <= 16 && micro.nbins == nb);
    let mask = ((1u32 << nb) - 1) as __mmask16;
    let cl = cell_len(nb);
    let (lo, hi) = taps.rows[cy];
    let stride = micro.nmx * nb;
    // The y-profile weights (times the gain) of the rows landing in this cell row, as the
    // portable fill computes them.
    let wys: Vec<(usize, [f32; PROFILES])> = (lo..hi)
        .filter_map(|my| taps.yt[my].map(|ty| (my, ty.w.map(|w| w * taps.gain))))
        .collect();
    for (cx, cell) in row.chunks_exact_mut(cl).enumerate().take(taps.ncx) {
        let (clo, chi) = taps.cols[cx];
        let mut t = [_mm512_setzero_ps(); PROFILES * PROFILES];
        for (i, (my, wy)) in wys.iter().enumerate() {
            let mut acc = [_mm512_setzero_ps(); PROFILES];
            let src = &micro.data[my * stride..][..stride];
            // SAFETY (both closures): `nb` half floats of micro-cell `mx` (< nmx) of this row.
            let load = |mx: usize| unsafe {
                _mm512_cvtph_ps(_mm256_maskz_loadu_epi16(
                    mask,
                    src.as_ptr().add(mx * nb) as *const i16,
                ))
            };
            match taps.split[cx] {
                // Left of `mid` x-profile 2 is exactly 0 and right of it x-profile 1 is: adding
                // `0·v` (+0) to a sum ≥ +0 changes no bit, so those products are skipped.
                Some(mid) => {
                    for mx in clo..mid {
                        let (w, vv) = (&taps.xw[mx], load(mx));
                        for p in LEFT_PROFILES {
                            acc[p] = _mm512_fmadd_ps(_mm512_set1_ps(w[p]), vv, acc[p]);
                        }
                    }
                    for mx in mid..chi {
                        let (w, vv) = (&taps.xw[mx], load(mx));
                        for p in RIGHT_PROFILES {
                            acc[p] = _mm512_fmadd_ps(_mm512_set1_ps(w[p]), vv, acc[p]);
                        }
                    }
                }
                None => {
                    for mx in clo..chi {
                        let (w, vv) = (&taps.xw[mx], load(mx));
                        for (a, &w) in acc.iter_mut().zip(w) {
                            *a = _mm512_fmadd_ps(_mm512_set1_ps(w), vv, *a);
                        }
                    }
                }
            }
            for (py, &w) in wy.iter().enumerate() {
                let wv = _mm512_set1_ps(w);
                let tr = &mut t[py * PROFILES..][..PROFILES];
                if i == 0 {
                    for (d, a) in tr.iter_mut().zip(&acc) {
                        *d = _mm512_mul_ps(wv, *a);
                    }
                } else if w != 0.0 {
                    for (d, a) in tr.iter_mut().zip(&acc) {
                        *d = _mm512_fmadd_ps(wv, *a, *d);
                    }
                }
            }
        }
        for py in 0..PROFILES {
            for px in 0..PROFILES {
                // SAFETY: `nb` lanes at the slot's offset, inside the cell's `cl` values.
                unsafe {
                    _mm512_mask_storeu_ps(
                        cell.as_mut_ptr().add(cell_slot(py, px) * nb),
                        mask,
                        t[py * PROFILES + px],
                    )
                };
            }
        }
    }
}

/// Horizontal pass of one micro row (`src`) into `h` (`[cell][x-profile][bin]`, every value
/// written): the row is converted to `f32` once into `v` ([`from_f16_row`]), then every
/// micro-cell adds its histogram times its four x-profile weights to its cell (fused
/// multiply-adds).
#[inline(always)]
fn hpass(nb: usize, xt: &[Option<AxisTap>], src: &[u16], h: &mut [f32], v: &mut Vec<f32>) {
    let hl = PROFILES * nb;
    h.fill(0.0);
    v.resize(src.len(), 0.0);
    from_f16_row(src, v);
    for (tx, mc) in xt.iter().zip(v.chunks_exact(nb)) {
        let Some(tx) = tx else { continue };
        let hc = &mut h[tx.cell * hl..][..hl];
        // All four x-profiles (zero weights add +0).
        for (hp, &wx) in hc.chunks_exact_mut(nb).zip(&tx.w) {
            for (d, &s) in hp.iter_mut().zip(mc) {
                *d = wx.mul_add(s, *d);
            }
        }
    }
}

/// Cell row `cy` of the approximated level (cell layout of [`super::CellGrid`], every value
/// written): each micro row landing in it is pooled horizontally into (cell, x-profile)
/// histograms, which are added with the row's y-profile weights (times the gain) into a
/// `[y-profile][cell][x-profile][bin]` buffer — one contiguous multiply-add per y-profile — and
/// that buffer is finally permuted into the cells' slots.
#[inline(always)]
fn fill_cell_row(
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
    s: &mut FillScratch,
    hpass: impl Fn(usize, &[Option<AxisTap>], &[u16], &mut [f32], &mut Vec<f32>),
) {
    // A literal bin count lets the compiler unroll and vectorise the default geometry.
    if micro.nbins == 9 {
        fill_cell_row_nb(9, micro, taps, cy, row, s, hpass)
    } else {
        fill_cell_row_nb(micro.nbins, micro, taps, cy, row, s, hpass)
    }
}

/// [`fill_cell_row`] for `nb` = `micro.nbins` bins.
#[inline(always)]
fn fill_cell_row_nb(
    nb: usize,
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
    s: &mut FillScratch,
    hpass: impl Fn(usize, &[Option<AxisTap>], &[u16], &mut [f32], &mut Vec<f32>),
) {
    let hl = PROFILES * nb;
    let plane = taps.ncx * hl;
    let FillScratch { h, t, v } = s;
    h.resize(taps.ncx * hl, 0.0);
    t.resize(PROFILES * plane, 0.0);
    let (lo, hi) = taps.rows[cy];
    let mut first = true;
    for (my, ty) in taps.yt.iter().enumerate().take(hi).skip(lo) {
        let Some(ty) = ty else { continue };
        hpass(
            nb,
            &taps.xt,
            &micro.data[my * micro.nmx * nb..][..micro.nmx * nb],
            h,
            v,
        );
        for (py, &wy) in ty.w.iter().enumerate() {
            let wy = wy * taps.gain;
            let tp = &mut t[py * plane..][..plane];
            if first {
                // `wy·s` is `0 + wy·s` to the bit (both ≥ +0): no zeroing pass.
                for (d, &s) in tp.iter_mut().zip(h.iter()) {
                    *d = wy * s;
                }
            } else if wy != 0.0 {
                for (d, &s) in tp.iter_mut().zip(h.iter()) {
                    *d = wy.mul_add(s, *d);
                }
            }
        }
        first = false;
    }
    if first {
        t.fill(0.0);
    }
    let cl = cell_len(nb);
    for (cx, cell) in row.chunks_exact_mut(cl).enumerate() {
        for py in 0..PROFILES {
            for px in 0..PROFILES {
                let src = &t[py * plane + cx * hl + px * nb..][..nb];
                let dst = &mut cell[cell_slot(py, px) * nb..][..nb];
                for (d, &v) in dst.iter_mut().zip(src) {
                    *d = v;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::hog::{blocks_from_cells, cell_grid_from_gamma_planes, CellGrid, HogOptions};
    use crate::image::Image;

    fn spec() -> HogSpec {
        HogSpec::new(&HogOptions::default()).unwrap()
    }

    fn plane(w: usize, h: usize) -> Image<f32> {
        Image::from_fn(w, h, |x, y| {
            let v = ((x * 7 + y * 3 + (x * y) / 5) % 97) as f32 + 40.0 * ((x as f32) * 0.05).sin();
            v.max(0.0).sqrt()
        })
    }

    /// The micro-cells of the grey plane `img`.
    fn micro(img: &Image<f32>, size: usize, exec: Exec) -> MicroGrid {
        let mut m = MicroGrid::empty();
        micro_grid_from_gamma_planes(&spec(), &GammaPlanes::Grey(img.view()), size, exec, &mut m).unwrap();
        m
    }

    #[test]
    fn continuous_profiles_match_the_discrete_ones() {
        let s = spec();
        for p in 0..PROFILES {
            for k in 0..CELL_SIZE {
                assert!(
                    (profile_at(&s, p, k as f32) - s.profile[p][k]).abs() < 1e-7,
                    "p {p} k {k}"
                );
            }
        }
    }

    #[test]
    fn unit_micro_cells_at_ratio_one_give_the_exact_blocks() {
        let s = spec();
        let img = plane(83, 150);
        let gp = GammaPlanes::Grey(img.view());
        let mut cells = CellGrid::empty();
        cell_grid_from_gamma_planes(&s, &gp, Exec::Serial, &mut cells).unwrap();
        let mut exact = BlockGrid::empty();
        blocks_from_cells(&s, &cells, Exec::Serial, &mut exact);
        let m = micro(&img, 1, Exec::Parallel);
        let mut got = BlockGrid::empty();
        blocks_from_micro_grid(&s, &m, 83, 150, 1.0, Exec::Parallel, &mut got);
        assert_eq!(
            (got.blocks_x(), got.blocks_y()),
            (exact.blocks_x(), exact.blocks_y())
        );
        let worst = got
            .data
            .iter()
            .zip(&exact.data)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(worst < 1e-4, "{worst}");
    }

    #[test]
    fn coarser_micro_cells_stay_close_to_exact_at_ratio_one() {
        let s = spec();
        let img = plane(96, 160);
        let gp = GammaPlanes::Grey(img.view());
        let mut exact = BlockGrid::empty();
        crate::features::hog::block_grid_from_gamma_planes(&s, &gp, Exec::Serial, &mut exact).unwrap();
        let m = micro(&img, 2, Exec::Serial);
        let mut got = BlockGrid::empty();
        blocks_from_micro_grid(&s, &m, 96, 160, 1.0, Exec::Serial, &mut got);
        let bl = s.block_len();
        let mut cos = 0.0;
        let n = got.data.len() / bl;
        for (a, b) in got.data.chunks(bl).zip(exact.data.chunks(bl)) {
            let dot: f32 = a.iter().zip(b).map(|(x, y)| x * y).sum();
            let na: f32 = a.iter().map(|x| x * x).sum::<f32>().sqrt();
            let nb: f32 = b.iter().map(|x| x * x).sum::<f32>().sqrt();
            cos += dot / (na * nb).max(1e-12);
        }
        assert!(cos / n as f32 > 0.97, "{}", cos / n as f32);
    }

    #[test]
    fn approximation_does_not_depend_on_threads() {
        let s = spec();
        let img = plane(200, 260);
        let (a, b) = (
            micro(&img, MICRO_CELL, Exec::Parallel),
            micro(&img, MICRO_CELL, Exec::Serial),
        );
        assert_eq!(a, b);
        let (mut ga, mut gb) = (BlockGrid::empty(), BlockGrid::empty());
        blocks_from_micro_grid(&s, &a, 131, 171, 0.7, Exec::Parallel, &mut ga);
        blocks_from_micro_grid(&s, &a, 131, 171, 0.7, Exec::Serial, &mut gb);
        assert_eq!(ga, gb);
        assert_eq!((ga.blocks_x(), ga.blocks_y()), (131 / 8 - 1, 171 / 8 - 1));
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let mut gc = BlockGrid::empty();
        pool.install(|| blocks_from_micro_grid(&s, &a, 131, 171, 0.7, Exec::Parallel, &mut gc));
        assert_eq!(ga, gc);
    }

    #[test]
    fn every_fill_kernel_gives_the_same_bits() {
        let s = spec();
        let img = plane(150, 170);
        let m = micro(&img, 2, Exec::Serial);
        for (w, h) in [(150, 170), (119, 133), (80, 128)] {
            let (ncx, ncy) = (w / CELL_SIZE, h / CELL_SIZE);
            let taps = Taps::new(&s, &m, w, h, 0.8);
            let run = |k: FillKernel| {
                let mut sc = FillScratch::new();
                let mut out = vec![f32::NAN; ncx * cell_len(9) * ncy];
                for (cy, row) in out.chunks_mut(ncx * cell_len(9)).enumerate() {
                    fill_with(k, &m, &taps, cy, row, &mut sc);
                }
                out
            };
            let want = run(FillKernel::Generic);
            assert!(want.iter().all(|v| v.is_finite()));
            let got = run(FillKernel::detect());
            assert!(
                want.iter().zip(&got).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{w}x{h}"
            );
        }
    }

    #[test]
    fn fused_cells_and_micro_cells_equal_the_two_passes() {
        // Sizes with and without a right / bottom margin past the last whole cell, several
        // bands, odd widths; grey, mosaic and colour planes; 1 and 2 workers.
        let s = spec();
        for (w, h) in [
            (160, 144),
            (173, 299),
            (66, 530),
            (174, 298),
            (301, 133),
            (71, 128),
        ] {
            let a = plane(w, h);
            let b = Image::from_fn(w, h, |x, y| a.get(w - 1 - x, y) * 0.7);
            let c = Image::from_fn(w, h, |x, y| a.get(x, h - 1 - y) + 1.0);
            let mut all = vec![
                GammaPlanes::Grey(a.view()),
                GammaPlanes::Colour([a.view(), b.view(), c.view()]),
            ];
            if w % 2 == 0 && h % 2 == 0 {
                all.push(GammaPlanes::Mosaic(a.view()));
            }
            for planes in all {
                for exec in [Exec::Serial, Exec::Parallel] {
                    let (mut want_b, mut want_m) = (BlockGrid::empty(), MicroGrid::empty());
                    crate::features::hog::block_grid_from_gamma_planes(&s, &planes, exec, &mut want_b)
                        .unwrap();
                    micro_grid_from_gamma_planes(&s, &planes, 2, exec, &mut want_m).unwrap();
                    let (mut got_b, mut got_m) = (BlockGrid::empty(), MicroGrid::empty());
                    // Stale contents in reused buffers must not leak through.
                    got_m.data = vec![0x7bff; 5];
                    block_and_micro_grids_from_gamma_planes(&s, &planes, 2, exec, &mut got_b, &mut got_m)
                        .unwrap();
                    assert_eq!(got_m, want_m, "{w}x{h} {exec:?}");
                    assert_eq!(got_b.blocks_x(), want_b.blocks_x());
                    assert_eq!(got_b.blocks_y(), want_b.blocks_y());
                    for by in 0..want_b.blocks_y() {
                        let (g, e) = (got_b.block_row(by), want_b.block_row(by));
                        assert!(
                            g.iter().zip(e).all(|(x, y)| x.to_bits() == y.to_bits()),
                            "{w}x{h} row {by}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn every_cell_run_splits_where_the_profiles_say() {
        // The AVX-512 fill skips x-profile 2 left of a cell's split and 1 right of it; the
        // split must exist for the detector's profiles at every ratio it uses (else that fill
        // falls back to all four products, still correct but slower).
        let s = spec();
        let m = micro(&plane(400, 300), 2, Exec::Serial);
        for k in 0..14 {
            let r = 1.05f64.powi(-k);
            let (w, h) = ((400.0 * r).round() as usize, (300.0 * r).round() as usize);
            let taps = Taps::new(&s, &m, w, h, 1.0);
            assert_eq!(taps.split.len(), w / CELL_SIZE);
            for (cx, (sp, &(lo, hi))) in taps.split.iter().zip(&taps.cols).enumerate() {
                let mid = sp.unwrap_or_else(|| panic!("ratio {r}: cell {cx} has no split"));
                assert!(lo < hi && (lo..=hi).contains(&mid), "ratio {r}: cell {cx}");
            }
        }
    }

    #[test]
    fn every_micro_kernel_gives_the_same_bits() {
        let s = spec();
        let img = plane(150, 170);
        let gp = GammaPlanes::Grey(img.view());
        let p = planes_of(&s, &gp).unwrap();
        let run = |avx2: bool| {
            let mut out = vec![0x7e00u16; (150 / 2) * 9 * 5];
            micro_rows_with(avx2, &p, 9, 2, 7, &mut out);
            out
        };
        let want = run(false);
        assert!(want.iter().all(|&v| f32_from_f16(v).is_finite()));
        assert_eq!(want, micro(&img, 2, Exec::Serial).data[7 * 75 * 9..12 * 75 * 9]);
        assert_eq!(want, run(have_avx2()));
    }

    #[test]
    fn half_floats_round_trip_and_match_the_hardware() {
        // Every half float converts to f32 and back unchanged (NaNs stay NaNs).
        for h in 0..=u16::MAX {
            let f = f32_from_f16(h);
            if f.is_nan() {
                assert!(f32_from_f16(f16_bits(f)).is_nan());
            } else {
                assert_eq!(f16_bits(f), h, "{h:#06x} = {f}");
            }
        }
        // Rounding: ties to even, overflow, subnormals, underflow.
        assert_eq!(f16_bits(1.0 + 2f32.powi(-11)), 0x3c00); // tie, even stays
        assert_eq!(f16_bits(1.0 + 3.0 * 2f32.powi(-11)), 0x3c02); // tie, odd rounds up
        assert_eq!(f16_bits(65520.0), 0x7c00); // rounds past the largest finite to infinity
        assert_eq!(f16_bits(65519.0), 0x7bff);
        assert_eq!(f16_bits(2f32.powi(-25)), 0); // tie between 0 and the smallest subnormal
        assert_eq!(f16_bits(2f32.powi(-25) * 1.5), 1);
        assert_eq!(f16_bits(-0.0), 0x8000);
        // The software conversion equals F16C's on values of every magnitude.
        let mut vals: Vec<f32> = (0..200_000u32)
            .map(|i| f32::from_bits(i.wrapping_mul(2_654_435_761) >> 1))
            .filter(|v| v.is_finite())
            .collect();
        vals.extend((0..4096).map(|i| i as f32 * 0.013 + 0.5));
        let mut hw = vec![0u16; vals.len()];
        to_f16_row(&vals, &mut hw);
        for (v, h) in vals.iter().zip(&hw) {
            assert_eq!(f16_bits(*v), *h, "{v:e}");
        }
        let all: Vec<u16> = (0..=u16::MAX).collect();
        let mut back = vec![0.0f32; all.len()];
        from_f16_row(&all, &mut back);
        for (&h, f) in all.iter().zip(&back) {
            assert_eq!(f.to_bits(), f32_from_f16(h).to_bits(), "{h:#06x}");
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        let s = spec();
        let img = plane(64, 128);
        let gp = GammaPlanes::Grey(img.view());
        let mut m = MicroGrid::empty();
        for size in [0, 9] {
            assert_eq!(
                micro_grid_from_gamma_planes(&s, &gp, size, Exec::Serial, &mut m),
                Err(HogError::BadMicroCell(size))
            );
        }
        let small = plane(60, 128);
        assert!(matches!(
            micro_grid_from_gamma_planes(&s, &GammaPlanes::Grey(small.view()), 4, Exec::Serial, &mut m),
            Err(HogError::ImageTooSmall { .. })
        ));
        let odd = plane(65, 128);
        assert!(matches!(
            micro_grid_from_gamma_planes(&s, &GammaPlanes::Mosaic(odd.view()), 4, Exec::Serial, &mut m),
            Err(HogError::OddMosaic { .. })
        ));
        // An empty micro grid gives an empty block grid.
        let mut g = BlockGrid::empty();
        blocks_from_micro_grid(&s, &MicroGrid::empty(), 64, 128, 1.0, Exec::Serial, &mut g);
        assert_eq!((g.blocks_x(), g.blocks_y()), (0, 0));
    }
}
