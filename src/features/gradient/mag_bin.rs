//! The fused kernel of the parent module: a `u8`/`u16` mosaic → `u16` magnitude and `u8`
//! orientation bin in one pass ([`mag_bin`]; the math, the magnitude shift and the bins are in
//! [`super`]'s docs), its scalar oracle, the chunked row body and its copies per instruction set,
//! and the dispatch to them.

use super::{
    check_same, check_size, for_each_row2, gradient_at, AngleRange, Border, GradientError, Operator,
    RawSample, CHUNK, DEFAULT_BINS, MAX_BINS,
};
use crate::image::{Image, ImageView, ImageViewMut};
use crate::kernels::{self, Isa};
use crate::raw::{RawFrame, RawView};

/// Options of the fused raw → (magnitude, orientation bin) kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MagBinOptions {
    /// Derivative operator.
    pub operator: Operator,
    /// Border mode.
    pub border: Border,
    /// Number of orientation bins over `range` (HOG: 9 over 180°; SIFT: 36 over 360°).
    pub bins: usize,
    /// Orientation range.
    pub range: AngleRange,
    /// Run on the calling thread only (`false`: row strips on the current rayon pool).
    pub serial: bool,
}

impl Default for MagBinOptions {
    fn default() -> Self {
        Self {
            operator: Operator::Central,
            border: Border::Reflect101,
            bins: DEFAULT_BINS,
            range: AngleRange::Unsigned,
            serial: false,
        }
    }
}

/// Validated [`MagBinOptions`] with the bin-edge table built once.
#[derive(Debug, Clone, PartialEq)]
pub struct MagBinSpec {
    opts: MagBinOptions,
    /// Bins over 180° (`bins` unsigned, `bins / 2` signed).
    half_bins: usize,
    /// `cos` of the bin edges in `(0°, 90°]`.
    cos: Vec<f32>,
    /// `sin` of the bin edges in `(0°, 90°]`.
    sin: Vec<f32>,
}

impl MagBinSpec {
    /// Validate options and build the edge table.
    pub fn new(opts: MagBinOptions) -> Result<Self, GradientError> {
        let bad = opts.bins == 0
            || opts.bins > MAX_BINS
            || (opts.range == AngleRange::Signed && !opts.bins.is_multiple_of(2));
        if bad {
            return Err(GradientError::Bins {
                bins: opts.bins,
                range: opts.range,
            });
        }
        let half_bins = match opts.range {
            AngleRange::Unsigned => opts.bins,
            AngleRange::Signed => opts.bins / 2,
        };
        let (mut cos, mut sin) = (Vec::new(), Vec::new());
        for k in 1..=half_bins / 2 {
            if 2 * k == half_bins {
                // Exactly 90°: exact values, so gx = 0 lands on the edge's upper side as ⌊θ/w⌋ does.
                cos.push(0.0);
                sin.push(1.0);
            } else {
                let e = (k as f64 * 180.0 / half_bins as f64).to_radians();
                cos.push(e.cos() as f32);
                sin.push(e.sin() as f32);
            }
        }
        Ok(Self {
            opts,
            half_bins,
            cos,
            sin,
        })
    }

    /// The options.
    pub fn options(&self) -> &MagBinOptions {
        &self.opts
    }

    /// Right shift applied to the magnitude so that it fits a `u16` at this bit depth.
    pub fn mag_shift(&self, bit_depth: u8) -> u32 {
        let max = std::f64::consts::SQRT_2
            * self.opts.operator.max_gain() as f64
            * ((1u64 << bit_depth.clamp(1, 16)) - 1) as f64;
        let mut s = 0;
        while max / f64::from(1u32 << s) + 0.5 >= 65536.0 {
            s += 1;
        }
        s
    }

    /// Scalar bin of one gradient (f32 components holding integers), the definition the fast
    /// kernels reproduce bit for bit.
    #[inline]
    pub fn bin_of(&self, gx: f32, gy: f32) -> u8 {
        if gx == 0.0 && gy == 0.0 {
            return 0;
        }
        let flip = gy < 0.0 || (gy == 0.0 && gx < 0.0);
        let (x, y) = if flip { (-gx, -gy) } else { (gx, gy) };
        let ax = x.abs();
        let (mut le, mut lt) = (0usize, 0usize);
        for (c, s) in self.cos.iter().zip(&self.sin) {
            let d = c * y - s * ax;
            le += (d >= 0.0) as usize;
            lt += (d > 0.0) as usize;
        }
        let b = if x >= 0.0 { le } else { self.half_bins - 1 - lt };
        let b = if flip && self.opts.range == AngleRange::Signed {
            b + self.half_bins
        } else {
            b
        };
        b as u8
    }
}

/// `round(√(gx² + gy²) · scale)` in f32, saturating; the definition of the fused magnitude.
#[inline(always)]
pub fn mag_of(gx: f32, gy: f32, scale: f32) -> u16 {
    ((gx * gx + gy * gy).sqrt() * scale + 0.5).min(65535.0) as u16
}

/// [`mag_of`] for the vector loops: identical result, but the final float → integer conversion is
/// an unchecked truncation, which vectorises (the saturating `as` cast does not).
#[inline(always)]
fn mag_of_fast(gx: f32, gy: f32, scale: f32) -> u16 {
    let m = ((gx * gx + gy * gy).sqrt() * scale + 0.5).min(65535.0);
    debug_assert!((0.0..=65535.0).contains(&m));
    // SAFETY: gx, gy are finite integers (differences of u16 values), so m is finite and lies in
    // [0.5, 65535]: in range of i32, where the unchecked truncation equals the `as` cast.
    unsafe { m.to_int_unchecked::<i32>() as u16 }
}

/// A fused kernel's output: magnitude and orientation bin per pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct MagBin {
    /// `round(√(gx² + gy²) / 2^mag_shift)`.
    pub mag: Image<u16>,
    /// Orientation bin.
    pub bin: Image<u8>,
    /// The shift applied to the magnitude ([`MagBinSpec::mag_shift`]).
    pub mag_shift: u32,
}

/// Per-row context of the fused kernel.
struct Ctx<'s> {
    spec: &'s MagBinSpec,
    scale: f32,
}

/// Interior pixels `1..w-1` of one interior row. Inlined into each path so each is compiled with
/// its own target features. Allocation-free: stack chunks of [`CHUNK`] pixels.
#[inline(always)]
fn row_interior<T: RawSample>(ctx: &Ctx<'_>, rp: &[T], r0: &[T], rn: &[T], mag: &mut [u16], bin: &mut [u8]) {
    let w = r0.len();
    let (spec, scale) = (ctx.spec, ctx.scale);
    let ne = spec.cos.len() as i32;
    let nh = spec.half_bins as i32;
    let signed = spec.opts.range == AngleRange::Signed;
    let mut x0 = 1;
    // Zeroed once per row, not per chunk: zeroing 2 KiB of stack per 256 pixels measured ~6 % of
    // the kernel's time (perf, 12 MP 8-bit).
    let (mut gx_buf, mut gy_buf) = ([0f32; CHUNK], [0f32; CHUNK]);
    while x0 + 1 < w {
        let n = CHUNK.min(w - 1 - x0);
        let (gx, gy) = (&mut gx_buf[..n], &mut gy_buf[..n]);
        let p = &rp[x0 - 1..x0 + n + 1];
        let c = &r0[x0 - 1..x0 + n + 1];
        let q = &rn[x0 - 1..x0 + n + 1];
        match spec.opts.operator {
            Operator::Central => {
                for i in 0..n {
                    gx[i] = (c[i + 2].to_i32() - c[i].to_i32()) as f32;
                    gy[i] = (q[i + 1].to_i32() - p[i + 1].to_i32()) as f32;
                }
            }
            Operator::Sobel => {
                for i in 0..n {
                    let b = c[i + 2].to_i32() - c[i].to_i32();
                    gx[i] = ((p[i + 2].to_i32() - p[i].to_i32())
                        + 2 * b
                        + (q[i + 2].to_i32() - q[i].to_i32())) as f32;
                    let e = q[i + 1].to_i32() - p[i + 1].to_i32();
                    gy[i] = ((q[i].to_i32() - p[i].to_i32())
                        + 2 * e
                        + (q[i + 2].to_i32() - p[i + 2].to_i32())) as f32;
                }
            }
        }
        let (mo, bo) = (&mut mag[x0..x0 + n], &mut bin[x0..x0 + n]);
        let fin = Fin {
            scale,
            ne,
            nh,
            signed,
        };
        // The edge count is a constant for the usual bin counts, so the per-pixel edge loop unrolls
        // and the whole finish is one vector loop.
        match ne {
            1 => finish_ne::<1>(&fin, gx, gy, &spec.cos, &spec.sin, mo, bo),
            2 => finish_ne::<2>(&fin, gx, gy, &spec.cos, &spec.sin, mo, bo),
            3 => finish_ne::<3>(&fin, gx, gy, &spec.cos, &spec.sin, mo, bo),
            4 => finish_ne::<4>(&fin, gx, gy, &spec.cos, &spec.sin, mo, bo),
            9 => finish_ne::<9>(&fin, gx, gy, &spec.cos, &spec.sin, mo, bo),
            _ => finish_dyn(&fin, gx, gy, &spec.cos, &spec.sin, mo, bo),
        }
        x0 += n;
    }
}

/// Constants of the finishing step (magnitude and bin from gx, gy).
struct Fin {
    scale: f32,
    /// Edges in (0°, 90°].
    ne: i32,
    /// Bins over 180°.
    nh: i32,
    signed: bool,
}

/// Bin base offset and the folded (x, my) used by the edge counts; see [`MagBinSpec::bin_of`].
/// Counting `cos·my − sin·x >= 0` over the edges gives `le` for x >= 0 and `ne − lt` for x < 0.
#[inline(always)]
fn fold(fin: &Fin, signed: bool, gx: f32, gy: f32) -> (f32, f32, i32) {
    let flip = gy < 0.0 || (gy == 0.0 && gx < 0.0);
    let (x, y) = if flip { (-gx, -gy) } else { (gx, gy) };
    let my = if x >= 0.0 { y } else { -y };
    let b = if x >= 0.0 { 0 } else { fin.nh - 1 - fin.ne };
    let b = if flip && signed { b + fin.nh } else { b };
    // A zero vector gets bin 0: start it at -ne; every edge then counts (d = 0).
    let b = if x == 0.0 && y == 0.0 { -fin.ne } else { b };
    (x, my, b)
}

/// [`finish_const`] with the angle range as a constant, so the unsigned loop (HOG's) carries no
/// select for the signed half: ≈20 % faster on the AVX-512 path (criterion, 1080p 8/12-bit).
#[inline(always)]
fn finish_ne<const NE: usize>(
    fin: &Fin,
    gx: &[f32],
    gy: &[f32],
    cos: &[f32],
    sin: &[f32],
    mag: &mut [u16],
    bin: &mut [u8],
) {
    if fin.signed {
        finish_const::<NE, true>(fin, gx, gy, cos, sin, mag, bin)
    } else {
        finish_const::<NE, false>(fin, gx, gy, cos, sin, mag, bin)
    }
}

#[inline(always)]
fn finish_const<const NE: usize, const SIGNED: bool>(
    fin: &Fin,
    gx: &[f32],
    gy: &[f32],
    cos: &[f32],
    sin: &[f32],
    mag: &mut [u16],
    bin: &mut [u8],
) {
    let n = gx.len();
    let (gy, mag, bin) = (&gy[..n], &mut mag[..n], &mut bin[..n]);
    let mut c = [0f32; NE];
    let mut s = [0f32; NE];
    c.copy_from_slice(&cos[..NE]);
    s.copy_from_slice(&sin[..NE]);
    for i in 0..n {
        mag[i] = mag_of_fast(gx[i], gy[i], fin.scale);
        let (x, my, mut b) = fold(fin, SIGNED, gx[i], gy[i]);
        for k in 0..NE {
            // `a >= b` is exactly `fl(a − b) >= 0` for finite floats (a − b rounds to 0 only when
            // a = b), so this equals the scalar definition bit for bit with one operation less.
            b += (c[k] * my >= s[k] * x) as i32;
        }
        bin[i] = b as u8;
    }
}

/// [`finish_const`] for any edge count: edges in the outer loop, so the pixel loops vectorise.
#[inline(always)]
fn finish_dyn(fin: &Fin, gx: &[f32], gy: &[f32], cos: &[f32], sin: &[f32], mag: &mut [u16], bin: &mut [u8]) {
    let n = gx.len();
    let (gy, mag, bin) = (&gy[..n], &mut mag[..n], &mut bin[..n]);
    let mut fx = [0f32; CHUNK];
    let mut my = [0f32; CHUNK];
    let mut cnt = [0i32; CHUNK];
    let (fx, my, cnt) = (&mut fx[..n], &mut my[..n], &mut cnt[..n]);
    for i in 0..n {
        mag[i] = mag_of_fast(gx[i], gy[i], fin.scale);
        (fx[i], my[i], cnt[i]) = fold(fin, fin.signed, gx[i], gy[i]);
    }
    for (&c, &s) in cos.iter().zip(sin) {
        for i in 0..n {
            cnt[i] += (c * my[i] >= s * fx[i]) as i32;
        }
    }
    for i in 0..n {
        bin[i] = cnt[i] as u8;
    }
}

/// Defines one copy of [`row_interior`] per kernel path, each compiled with its own target
/// features (the attributes given), all with the same signature.
macro_rules! row_interior_copy {
    ($(#[$m:meta])* unsafe fn $name:ident) => {
        $(#[$m])*
        unsafe fn $name<T: RawSample>(ctx: &Ctx<'_>, rp: &[T], r0: &[T], rn: &[T], mag: &mut [u16], bin: &mut [u8]) {
            row_interior(ctx, rp, r0, rn, mag, bin)
        }
    };
    ($(#[$m:meta])* fn $name:ident) => {
        $(#[$m])*
        fn $name<T: RawSample>(ctx: &Ctx<'_>, rp: &[T], r0: &[T], rn: &[T], mag: &mut [u16], bin: &mut [u8]) {
            row_interior(ctx, rp, r0, rn, mag, bin)
        }
    };
}

row_interior_copy!(
    /// The baseline copy ([`Isa::Scalar`]): the chunked body built for the compile target (SSE2 on
    /// x86-64).
    fn row_interior_baseline
);

row_interior_copy!(
    /// # Safety
    /// The CPU must support AVX2 and FMA (checked by [`Isa::is_available`] before this path is chosen).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn row_interior_avx2
);

row_interior_copy!(
    /// # Safety
    /// The CPU must support AVX-512 F/BW/VL (checked by [`Isa::is_available`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,avx512f,avx512bw,avx512vl")]
    unsafe fn row_interior_avx512
);

row_interior_copy!(
    /// The NEON copy ([`Isa::Neon`]): Advanced SIMD is part of the aarch64 baseline, so this is the
    /// body as LLVM vectorises it for 128-bit registers (widening `ushll`, `scvtf`, `fmul`,
    /// `fsqrt`, `fcmge`/`bsl` on `v.4s`, narrowing `xtn`; checked in the cross build's assembly,
    /// docs/gradients.md "Benchmark").
    #[cfg(target_arch = "aarch64")]
    fn row_interior_neon
);

/// Magnitude and bin at one pixel through the scalar definitions (border pixels and the oracle).
#[inline]
fn pixel_scalar<T: RawSample>(src: &ImageView<'_, T>, ctx: &Ctx<'_>, x: usize, y: usize) -> (u16, u8) {
    let get = |x: usize, y: usize| src.get(x, y).to_i32();
    let o = &ctx.spec.opts;
    let (gx, gy): (i32, i32) = gradient_at(&get, src.width(), src.height(), o.operator, o.border, x, y);
    let (gx, gy) = (gx as f32, gy as f32);
    (mag_of(gx, gy, ctx.scale), ctx.spec.bin_of(gx, gy))
}

/// How [`mag_bin_typed`] computes the interior: the per-pixel oracle or a kernel path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Route {
    /// Every pixel through [`pixel_scalar`].
    Oracle,
    /// The chunked body compiled for this path (available here).
    Kernel(Isa),
}

fn mag_bin_typed<T: RawSample>(
    src: &ImageView<'_, T>,
    bit_depth: u8,
    spec: &MagBinSpec,
    route: Route,
    mag: &mut ImageViewMut<'_, u16>,
    bin: &mut ImageViewMut<'_, u8>,
) -> Result<(), GradientError> {
    let (w, h) = (src.width(), src.height());
    if !(1..=16).contains(&bit_depth) {
        return Err(GradientError::BitDepth { bit_depth });
    }
    check_size(w, h, spec.opts.border)?;
    check_same("magnitude", (mag.width(), mag.height()), (w, h))?;
    check_same("bin", (bin.width(), bin.height()), (w, h))?;
    let route = match route {
        Route::Kernel(isa) if !isa.is_available() => Route::Kernel(Isa::Scalar),
        r => r,
    };
    let ctx = Ctx {
        spec,
        scale: 1.0 / (1u32 << spec.mag_shift(bit_depth)) as f32,
    };
    for_each_row2(mag, bin, spec.opts.serial, |y, mrow, brow| {
        let interior_row = y >= 1 && y + 1 < h;
        if route == Route::Oracle || !interior_row {
            for x in 0..w {
                (mrow[x], brow[x]) = pixel_scalar(src, &ctx, x, y);
            }
            return;
        }
        for x in [0, w - 1] {
            (mrow[x], brow[x]) = pixel_scalar(src, &ctx, x, y);
        }
        let (rp, r0, rn) = (src.row(y - 1), src.row(y), src.row(y + 1));
        match route {
            #[cfg(target_arch = "x86_64")]
            Route::Kernel(Isa::Avx2) => {
                debug_assert!(Isa::Avx2.is_available());
                // SAFETY: AVX2 + FMA support was checked above (`is_available` probes it at run
                // time). The same code built for AVX2 is several times faster than the SSE2
                // baseline build (docs/gradients.md).
                unsafe { row_interior_avx2(&ctx, rp, r0, rn, mrow, brow) }
            }
            #[cfg(target_arch = "x86_64")]
            Route::Kernel(Isa::Avx512) => {
                debug_assert!(Isa::Avx512.is_available());
                // SAFETY: AVX-512 F/BW/VL support was checked above (`is_available`).
                unsafe { row_interior_avx512(&ctx, rp, r0, rn, mrow, brow) }
            }
            #[cfg(target_arch = "aarch64")]
            Route::Kernel(Isa::Neon) => row_interior_neon(&ctx, rp, r0, rn, mrow, brow),
            _ => row_interior_baseline(&ctx, rp, r0, rn, mrow, brow),
        }
    });
    Ok(())
}

/// The fused kernel: a `u8`/`u16` mosaic (or grey image) → `u16` magnitude and `u8` orientation bin,
/// one pass, on the process's kernel path ([`crate::kernels::isa`]: the widest this CPU has, or
/// the one `MOSAICD_KERNELS` names).
///
/// Row strips of [`STRIP_ROWS`](super::STRIP_ROWS) run on the *current* rayon pool: the daemon calls it inside its own
/// `ThreadPool::install`; with `serial` set in the options it stays on the calling thread.
/// `bit_depth` sets the magnitude shift ([`MagBinSpec::mag_shift`]). The black level is not needed:
/// it cancels in every difference (module docs). No allocation.
pub fn mag_bin(
    src: RawView<'_>,
    bit_depth: u8,
    spec: &MagBinSpec,
    mag: &mut ImageViewMut<'_, u16>,
    bin: &mut ImageViewMut<'_, u8>,
) -> Result<(), GradientError> {
    mag_bin_with_isa(src, bit_depth, spec, kernels::isa(), mag, bin)
}

/// [`mag_bin`] through the per-pixel scalar definition: the test oracle.
pub fn mag_bin_scalar(
    src: RawView<'_>,
    bit_depth: u8,
    spec: &MagBinSpec,
    mag: &mut ImageViewMut<'_, u16>,
    bin: &mut ImageViewMut<'_, u8>,
) -> Result<(), GradientError> {
    mag_bin_routed(src, bit_depth, spec, Route::Oracle, mag, bin)
}

/// [`mag_bin`] on a chosen kernel path (a path this CPU cannot run falls back to
/// [`Isa::Scalar`], the baseline build of the same body). Every path equals [`mag_bin_scalar`]
/// bit for bit.
pub fn mag_bin_with_isa(
    src: RawView<'_>,
    bit_depth: u8,
    spec: &MagBinSpec,
    isa: Isa,
    mag: &mut ImageViewMut<'_, u16>,
    bin: &mut ImageViewMut<'_, u8>,
) -> Result<(), GradientError> {
    mag_bin_routed(src, bit_depth, spec, Route::Kernel(isa), mag, bin)
}

fn mag_bin_routed(
    src: RawView<'_>,
    bit_depth: u8,
    spec: &MagBinSpec,
    route: Route,
    mag: &mut ImageViewMut<'_, u16>,
    bin: &mut ImageViewMut<'_, u8>,
) -> Result<(), GradientError> {
    match src {
        RawView::U8(v) => mag_bin_typed(&v, bit_depth, spec, route, mag, bin),
        RawView::U16(v) => mag_bin_typed(&v, bit_depth, spec, route, mag, bin),
    }
}

/// Allocating wrapper of [`mag_bin`] for a [`RawFrame`] (its bit depth sets the magnitude shift).
pub fn mag_bin_from_raw(frame: &RawFrame, spec: &MagBinSpec) -> Result<MagBin, GradientError> {
    let (w, h) = (frame.width(), frame.height());
    let mut mag = Image::new(w, h);
    let mut bin = Image::new(w, h);
    mag_bin(
        frame.view(),
        frame.bit_depth(),
        spec,
        &mut mag.view_mut(),
        &mut bin.view_mut(),
    )?;
    Ok(MagBin {
        mag,
        bin,
        mag_shift: spec.mag_shift(frame.bit_depth()),
    })
}
