//! The scalar oracle of the channel kernels and what it shares with the channel code (the
//! orientation bins, Dollár's LUV constants and [`luv_from_rgb`]): below the dispatch in `mod.rs`,
//! the per-ISA files and `channels/mod.rs`, which all use it.

/// Orientation channels (Dollár's `nOrients`).
pub(crate) const N_ORIENTS: usize = 6;

/// `(cos e, sin e)` of the six orientation bin edges 15°, 45°, …, 165° (see
/// [`orient_bin`]).
pub(crate) type Edges = [(f32, f32); N_ORIENTS];

/// `(cos, sin)` of the orientation bin edges 15°, 45°, …, 165°.
pub(crate) fn bin_edges() -> [(f32, f32); N_ORIENTS] {
    std::array::from_fn(|k| {
        let e = ((15 + 30 * k) as f64).to_radians();
        (e.cos() as f32, e.sin() as f32)
    })
}

/// Orientation bin of the gradient `(gx, gy)`: the nearest of the six bin centres `30°·k` of the
/// unsigned angle, found by counting the edges `e` below it with `gy·cos e − gx·sin e ≥ 0` after
/// folding the vector into the upper half-plane. Equal to `round(6θ/π) mod 6` except within float
/// rounding of an edge; the zero vector gets bin 0.
#[inline]
pub(crate) fn orient_bin(gx: f32, gy: f32, edges: &[(f32, f32); N_ORIENTS]) -> u8 {
    let (gx, gy) = if gy < 0.0 || (gy == 0.0 && gx < 0.0) {
        (-gx, -gy)
    } else {
        (gx, gy)
    };
    let c: u8 = edges.iter().map(|&(c, s)| (gy * c - gx * s >= 0.0) as u8).sum();
    c % N_ORIENTS as u8
}

/// The scalar oracle of `grad_row` for pixels `from..mag.len()` (also the SIMD tails).
pub(crate) fn grad_row_scalar(
    up: &[f32],
    mid: &[f32],
    dn: &[f32],
    edges: &Edges,
    from: usize,
    mag: &mut [f32],
    bin: &mut [u8],
) {
    for x in from.max(1)..mag.len() {
        let gx = (mid[x + 1] - mid[x - 1]) * 0.5;
        let gy = (dn[x] - up[x]) * 0.5;
        mag[x] = (gx * gx + gy * gy).sqrt();
        bin[x] = orient_bin(gx, gy, edges);
    }
}

/// The scalar oracle of `normalise` from index `from` on (also the SIMD tails).
pub(crate) fn normalise_scalar(m: &[f32], n: &[f32], c: f32, out: &mut [f32], from: usize) {
    for x in from..out.len() {
        out[x] = m[x] / (n[x] + c);
    }
}

/// The scalar oracle of `taps_sum` from index `from` on (also the SIMD tails).
pub(crate) fn taps_sum_scalar(out: &mut [f32], srcs: &[&[f32]], taps: &[f32], from: usize) {
    for (x, o) in out.iter_mut().enumerate().skip(from) {
        let mut acc = 0.0f32;
        for (src, &t) in srcs.iter().zip(taps) {
            acc += t * src[x];
        }
        *o = acc;
    }
}

/// Pixels per block side (the channels' `SHRINK`).
pub(crate) const BLOCK: usize = 4;

/// The scalar oracle of `aggregate` for blocks `from..` (also the SIMD tails).
pub(crate) fn aggregate_scalar(
    v: &[f32],
    bins: &[u8],
    gw: usize,
    inv: f32,
    out: &mut [f32],
    ostride: usize,
    from: usize,
) {
    for bx in from..gw / BLOCK {
        let mut a = [0.0f32; 1 + N_ORIENTS];
        for r in 0..BLOCK {
            for x in bx * BLOCK..(bx + 1) * BLOCK {
                let (val, b) = (v[r * gw + x], bins[r * gw + x]);
                a[0] += val;
                a[1 + b as usize] += val;
            }
        }
        for (k, a) in a.iter().enumerate() {
            out[k * ostride + bx] = a * inv;
        }
    }
}

/// The scalar oracle of `luv_row` from index `from` on (also the SIMD tails): Dollár's LUV of
/// each `(r, g, b)`.
pub(crate) fn luv_row_scalar(rgb: [&[f32]; 3], luv: [&mut [f32]; 3], from: usize) {
    let [r, g, b] = rgb;
    let [l, u, v] = luv;
    for i in from..l.len() {
        [l[i], u[i], v[i]] = luv_from_rgb(r[i], g[i], b[i]);
    }
}

// Dollár's rgbConvert LUV constants (rgbConvertMex.cpp, `rgb2luv_setup`).
pub(crate) const LUV_MR: [f32; 3] = [0.430574, 0.222015, 0.020183];
pub(crate) const LUV_MG: [f32; 3] = [0.341550, 0.706655, 0.129553];
pub(crate) const LUV_MB: [f32; 3] = [0.178325, 0.071330, 0.939180];
pub(crate) const LUV_UN: f32 = 0.197833;
pub(crate) const LUV_VN: f32 = 0.468331;
pub(crate) const LUV_MAXI: f32 = 1.0 / 270.0;
pub(crate) const LUV_MINU: f32 = -88.0 * LUV_MAXI;
pub(crate) const LUV_MINV: f32 = -134.0 * LUV_MAXI;
/// `(6/29)³`: below it `L` is linear in `Y`.
pub(crate) const LUV_Y0: f32 = 0.008_856_452;
/// `(29/3)³`: the slope of the linear part.
pub(crate) const LUV_A: f32 = 903.296_3;

/// Dollár's LUV of `(r, g, b)` in `[0, 1]`.
pub(crate) fn luv_from_rgb(r: f32, g: f32, b: f32) -> [f32; 3] {
    let x = LUV_MR[0] * r + LUV_MG[0] * g + LUV_MB[0] * b;
    let y = LUV_MR[1] * r + LUV_MG[1] * g + LUV_MB[1] * b;
    let z = LUV_MR[2] * r + LUV_MG[2] * g + LUV_MB[2] * b;
    let l = if y > LUV_Y0 {
        116.0 * y.cbrt() - 16.0
    } else {
        y * LUV_A
    } * LUV_MAXI;
    let d = 1.0 / (x + 15.0 * y + 3.0 * z + 1e-35);
    let u = l * (13.0 * 4.0 * x * d - 13.0 * LUV_UN) - LUV_MINU;
    let v = l * (13.0 * 9.0 * y * d - 13.0 * LUV_VN) - LUV_MINV;
    [l, u, v]
}
