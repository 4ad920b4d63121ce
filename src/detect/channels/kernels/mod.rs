//! Per-instruction-set kernels of the channel computation ([`super`]): every intrinsic of the
//! channels lives here, one file per ISA; the scalar code below is the oracle.
//!
//! | kernel | scalar (oracle) | AVX2 (AVX-512 runs it too) | NEON |
//! |---|---|---|---|
//! | gradient row: magnitude and orientation bin of one plane | per pixel | 8 pixels | 4 pixels |
//! | normalised magnitude `m / (n + c)` | per pixel | 8 pixels | 4 pixels |
//! | `out = Σ_k t_k·src_k` from 0, in tap order (the triangle filter's passes) | per value | 8 values | 4 values |
//! | block aggregation: magnitude and six orientation sums of 4x4 pixels | per block | 8 blocks (4x8 transposition) | 8 blocks (`vld4`) |
//! | Dollár's LUV of `(r, g, b)` | per value | 8 values | 4 values |
//!
//! The resampling of the approximated levels is the crate's one bilinear resize
//! ([`crate::resize::resize_planes_scaled`]), which has its own kernels.
//!
//! Every kernel is the same IEEE operations in the same order on every path (multiplications
//! and additions kept separate, never fused; `sqrt` and division correctly rounded; each block
//! sum adds its pixels row by row, left to right), so every path equals the oracle **bit for
//! bit**. The AVX-512 path runs the AVX2 kernels: these loops are bound by loads and stores, not
//! by the vector width. The LUV kernel takes `Y^⅓` from the platform's `cbrtf` (`f32::cbrt`) on
//! every path, one lane at a time (the oracle's function, so its bits), and vectorises the rest.

use crate::kernels::Isa;

pub(crate) use scalar::{bin_edges, grad_row_scalar, normalise_scalar, orient_bin, Edges, BLOCK};
pub use scalar::{luv_from_rgb, N_ORIENTS};

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "aarch64")]
mod neon;
mod scalar;

/// Gradient magnitude and orientation bin of pixels `1..mag.len()` of a row of one plane with
/// rows `up`, `mid`, `dn` (the rows above and below, already reflected at the image border):
/// `gx = (mid[x+1] − mid[x−1])/2`, `gy = (dn[x] − up[x])/2`, `mag = √(gx² + gy²)`,
/// `bin = orient_bin(gx, gy)`. Pixel 0 is left untouched (its left neighbour is a border case).
///
/// # Panics
/// If `mid` has fewer than `mag.len() + 1` values, `up`/`dn` fewer than `mag.len()`, or
/// `bin.len() != mag.len()`.
pub(crate) fn grad_row(
    isa: Isa,
    up: &[f32],
    mid: &[f32],
    dn: &[f32],
    edges: &Edges,
    mag: &mut [f32],
    bin: &mut [u8],
) {
    let n = mag.len();
    assert!(
        bin.len() == n && mid.len() > n && up.len() >= n && dn.len() >= n,
        "gradient row: {n} outputs need a row of {} and rows of {n} (got {}, {}, {}, {})",
        n + 1,
        mid.len(),
        up.len(),
        dn.len(),
        bin.len()
    );
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the AVX2 and AVX-512 paths are chosen only when the CPU has AVX2
        // (`Isa::is_available`); lengths checked above.
        Isa::Avx2 | Isa::Avx512 => unsafe { avx2::grad_row(up, mid, dn, edges, mag, bin) },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 target; lengths checked above.
        Isa::Neon => unsafe { neon::grad_row(up, mid, dn, edges, mag, bin) },
        _ => grad_row_scalar(up, mid, dn, edges, 1, mag, bin),
    }
}

/// `out[x] = m[x] / (n[x] + c)` (the magnitude normalisation).
///
/// # Panics
/// If the slices differ in length.
pub(crate) fn normalise(isa: Isa, m: &[f32], n: &[f32], c: f32, out: &mut [f32]) {
    assert!(
        m.len() == out.len() && n.len() == out.len(),
        "normalise: lengths {}, {}, {}",
        m.len(),
        n.len(),
        out.len()
    );
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 is available on these paths (`Isa::is_available`); lengths checked.
        Isa::Avx2 | Isa::Avx512 => unsafe { avx2::normalise(m, n, c, out) },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 target; lengths checked.
        Isa::Neon => unsafe { neon::normalise(m, n, c, out) },
        _ => normalise_scalar(m, n, c, out, 0),
    }
}

/// `out[i] = (…((0 + t₀·src₀[i]) + t₁·src₁[i]) + …)`: the taps in order, each a product then a
/// sum (never fused).
///
/// # Panics
/// If `srcs` and `taps` differ in length or a source is shorter than `out`.
pub(crate) fn taps_sum(isa: Isa, out: &mut [f32], srcs: &[&[f32]], taps: &[f32]) {
    assert!(
        srcs.len() == taps.len() && srcs.iter().all(|s| s.len() >= out.len()),
        "taps_sum: {} sources for {} taps, {} values",
        srcs.len(),
        taps.len(),
        out.len()
    );
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 is available on these paths (`Isa::is_available`); lengths checked.
        Isa::Avx2 | Isa::Avx512 => unsafe { avx2::taps_sum(out, srcs, taps) },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 target; lengths checked.
        Isa::Neon => unsafe { neon::taps_sum(out, srcs, taps) },
        _ => scalar::taps_sum_scalar(out, srcs, taps, 0),
    }
}

/// Block sums of one row of 4x4-pixel blocks: `v` and `bins` hold the 4 pixel rows of `gw`
/// values (a multiple of 4) one after the other; block `bx` writes `inv ·` its magnitude sum to
/// `out[bx]` and `inv ·` the sum of its pixels of orientation bin `o` to `out[(1 + o)·ostride +
/// bx]`. Each sum adds the block's pixels row by row, left to right, from `0.0`. Bins must be
/// below [`N_ORIENTS`].
///
/// # Panics
/// If `gw` is not a multiple of 4, `v` or `bins` hold fewer than `4·gw` values, `ostride <
/// gw/4` or `out` is shorter than `6·ostride + gw/4`.
pub(crate) fn aggregate(
    isa: Isa,
    v: &[f32],
    bins: &[u8],
    gw: usize,
    inv: f32,
    out: &mut [f32],
    ostride: usize,
) {
    let cw = gw / scalar::BLOCK;
    assert!(
        gw.is_multiple_of(scalar::BLOCK)
            && v.len() >= scalar::BLOCK * gw
            && bins.len() >= scalar::BLOCK * gw
            && ostride >= cw
            && out.len() >= N_ORIENTS * ostride + cw,
        "aggregate: rows of {gw}, {} values, {} bins, output {} with stride {ostride}",
        v.len(),
        bins.len(),
        out.len()
    );
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 is available on these paths (`Isa::is_available`); lengths checked.
        Isa::Avx2 | Isa::Avx512 => unsafe { avx2::aggregate(v, bins, gw, inv, out, ostride) },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 target; lengths checked.
        Isa::Neon => unsafe { neon::aggregate(v, bins, gw, inv, out, ostride) },
        _ => scalar::aggregate_scalar(v, bins, gw, inv, out, ostride, 0),
    }
}

/// Dollár's LUV ([`crate::detect::channels::luv_from_rgb`]) of `(r[i], g[i], b[i])` into
/// `(l[i], u[i], v[i])`.
///
/// # Panics
/// If the six slices differ in length.
pub(crate) fn luv_row(isa: Isa, rgb: [&[f32]; 3], luv: [&mut [f32]; 3]) {
    let n = luv[0].len();
    assert!(
        rgb.iter().all(|c| c.len() == n) && luv.iter().all(|c| c.len() == n),
        "luv_row: lengths {:?} -> {:?}",
        rgb.map(|c| c.len()),
        luv.each_ref().map(|c| c.len())
    );
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 is available on these paths (`Isa::is_available`); lengths checked.
        Isa::Avx2 | Isa::Avx512 => unsafe { avx2::luv_row(rgb, luv) },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 target; lengths checked.
        Isa::Neon => unsafe { neon::luv_row(rgb, luv) },
        _ => scalar::luv_row_scalar(rgb, luv, 0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn kernel_paths_equal_the_scalar_oracle() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let edges = bin_edges();
        for len in [1usize, 2, 7, 9, 16, 17, 64, 203] {
            // values on a coarse grid make zero and tied gradients (the fold's edge cases) common
            let row = |rng: &mut rand_chacha::ChaCha8Rng| -> Vec<f32> {
                (0..len + 1)
                    .map(|_| rng.random_range(0..6) as f32 * 0.25)
                    .collect()
            };
            let (up, mid, dn) = (row(&mut rng), row(&mut rng), row(&mut rng));
            let mut want = (vec![0.0f32; len], vec![0u8; len]);
            grad_row_scalar(&up, &mid, &dn, &edges, 1, &mut want.0, &mut want.1);
            let m: Vec<f32> = (0..len).map(|_| rng.random_range(0.0..3.0)).collect();
            let nn: Vec<f32> = (0..len).map(|_| rng.random_range(0.0..1.0)).collect();
            let mut want_n = vec![0.0f32; len];
            normalise_scalar(&m, &nn, 0.005, &mut want_n, 0);
            for isa in Isa::available() {
                let mut got = (vec![0.0f32; len], vec![0u8; len]);
                grad_row(isa, &up, &mid, &dn, &edges, &mut got.0, &mut got.1);
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got.0), bits(&want.0), "{isa} magnitudes, {len}");
                assert_eq!(got.1, want.1, "{isa} bins, {len}");
                let mut got_n = vec![0.0f32; len];
                normalise(isa, &m, &nn, 0.005, &mut got_n);
                assert_eq!(bits(&got_n), bits(&want_n), "{isa} normalised, {len}");
            }
        }
    }

    #[test]
    fn kernel_paths_luv_equal_the_scalar_oracle() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for len in [0usize, 1, 3, 4, 7, 8, 9, 17, 203] {
            // around L's knee Y0 (both branches in one vector), black, white, above 1, NaN
            let val = |rng: &mut rand_chacha::ChaCha8Rng| match rng.random_range(0..8) {
                0 => rng.random_range(0.0..0.03),
                1 => 0.0,
                2 => 1.0,
                3 => rng.random_range(1.0..4.0),
                4 if rng.random_range(0..20) == 0 => f32::NAN,
                _ => rng.random_range(0.0..1.0),
            };
            let rgb: [Vec<f32>; 3] = std::array::from_fn(|_| (0..len).map(|_| val(&mut rng)).collect());
            let mut want: [Vec<f32>; 3] = std::array::from_fn(|_| vec![f32::NAN; len]);
            let [l, u, v] = &mut want;
            scalar::luv_row_scalar([&rgb[0], &rgb[1], &rgb[2]], [l, u, v], 0);
            // the oracle is luv_from_rgb
            if len > 0 {
                let one = scalar::luv_from_rgb(rgb[0][0], rgb[1][0], rgb[2][0]);
                assert_eq!(bits(&one), bits(&[want[0][0], want[1][0], want[2][0]]));
            }
            for isa in Isa::available() {
                let mut got: [Vec<f32>; 3] = std::array::from_fn(|_| vec![f32::NAN; len]);
                let [l, u, v] = &mut got;
                luv_row(isa, [&rgb[0], &rgb[1], &rgb[2]], [l, u, v]);
                for c in 0..3 {
                    assert_eq!(
                        bits(&got[c]),
                        bits(&want[c]),
                        "{isa} LUV channel {c}, {len} values"
                    );
                }
            }
        }
    }

    #[test]
    fn kernel_paths_taps_sum_and_aggregate_equal_the_scalar_oracle() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for len in [0usize, 1, 7, 8, 9, 31, 203] {
            for n in [1usize, 3, 11] {
                let srcs: Vec<Vec<f32>> = (0..n)
                    .map(|_| (0..len + 3).map(|_| rng.random_range(-2.0..2.0)).collect())
                    .collect();
                let refs: Vec<&[f32]> = srcs.iter().map(|v| &v[..]).collect();
                let taps: Vec<f32> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
                let mut want = vec![f32::NAN; len];
                scalar::taps_sum_scalar(&mut want, &refs, &taps, 0);
                // the oracle is the plain sum from 0, taps in order
                if len > 0 {
                    let s0 = (0..n).fold(0.0f32, |a, k| a + taps[k] * srcs[k][0]);
                    assert_eq!(want[0].to_bits(), s0.to_bits());
                }
                for isa in Isa::available() {
                    let mut got = vec![f32::NAN; len];
                    taps_sum(isa, &mut got, &refs, &taps);
                    assert_eq!(bits(&got), bits(&want), "{isa} taps_sum, {len} values, {n} taps");
                }
            }
        }
        // widths of 1 to 21 blocks (the SIMD groups of 8 and their tails), a padded output stride
        for cw in [1usize, 7, 8, 9, 16, 21] {
            let gw = 4 * cw;
            let v: Vec<f32> = (0..4 * gw)
                .map(|_| match rng.random_range(0..4) {
                    0 => 0.0,
                    _ => rng.random_range(0.0..3.0),
                })
                .collect();
            let bins: Vec<u8> = (0..4 * gw)
                .map(|_| rng.random_range(0..N_ORIENTS as u8))
                .collect();
            let ostride = cw + 3;
            let mut want = vec![-1.0f32; 7 * ostride];
            scalar::aggregate_scalar(&v, &bins, gw, 1.0 / 16.0, &mut want, ostride, 0);
            // the oracle is the plain per-block sum
            let b0: f32 = (0..4)
                .flat_map(|r| (0..4).map(move |x| r * gw + x))
                .map(|i| v[i])
                .sum();
            assert_eq!(want[0], b0 / 16.0);
            for isa in Isa::available() {
                let mut got = vec![-1.0f32; 7 * ostride];
                aggregate(isa, &v, &bins, gw, 1.0 / 16.0, &mut got, ostride);
                assert_eq!(bits(&got), bits(&want), "{isa} aggregate, {cw} blocks");
            }
        }
    }
}
