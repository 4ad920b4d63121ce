//! The 4x4x8 SIFT descriptor (OpenCV `calcSIFTDescriptor`): gradients in a rotated grid of
//! 4x4 cells around the keypoint, trilinear interpolation into 8 orientation bins, normalise,
//! clip at 0.2, renormalise, scale by 512 and saturate to `u8` (OpenCV's stored values).

use super::detect::{floor, Candidate, GradScratch};
use crate::image::Image;
use crate::kernels::Isa;

/// Cells per side of the descriptor grid (`SIFT_DESCR_WIDTH`).
pub(crate) const SIFT_DESCR_WIDTH: usize = 4;
/// Orientation bins per cell (`SIFT_DESCR_HIST_BINS`).
pub(crate) const SIFT_DESCR_HIST_BINS: usize = 8;
/// Cell width in keypoint scales (`SIFT_DESCR_SCL_FCTR`).
const SIFT_DESCR_SCL_FCTR: f32 = 3.0;
/// Clip threshold on the normalised histogram (`SIFT_DESCR_MAG_THR`).
const SIFT_DESCR_MAG_THR: f32 = 0.2;
/// Scale from the unit vector to the stored integer range (`SIFT_INT_DESCR_FCTR`).
const SIFT_INT_DESCR_FCTR: f32 = 512.0;
/// Descriptor length: 4 x 4 cells x 8 bins.
pub const DESCRIPTOR_LEN: usize = SIFT_DESCR_WIDTH * SIFT_DESCR_WIDTH * SIFT_DESCR_HIST_BINS;

/// Bins from the first to the last of the eight a sample adds to.
const SPAN: usize = (SIFT_DESCR_WIDTH + 3) * (SIFT_DESCR_HIST_BINS + 2) + 2;

/// Half-width of the rotated grid in cell units: a sample is inside when `|c_rot|, |r_rot| <
/// d / 2 + 0.5` (`rbin`, `cbin` in (-1, d)).
const GRID_HALF: f64 = SIFT_DESCR_WIDTH as f64 / 2.0 + 0.5;
/// Slack added to [`GRID_HALF`] for the interval below; the f32 rotation is off by ~1e-6.
const GRID_SLACK: f64 = 1e-3;

/// Columns `j0..=j1` of window row `i` that can lie inside the rotated grid: the exact per-sample
/// test still decides, this only skips columns that are certainly outside (about half of the
/// square window). `c_rot = j cos_t - i sin_t` and `r_rot = j sin_t + i cos_t` are linear in
/// `j`, so each bound is an interval, widened by [`GRID_SLACK`] and one column.
fn inside_columns(i: i64, cos_t: f32, sin_t: f32, radius: i64) -> (i64, i64) {
    let (mut lo, mut hi) = (-radius as f64, radius as f64);
    let lim = GRID_HALF + GRID_SLACK;
    // c_rot: j cos_t in (-lim + i sin_t, lim + i sin_t); r_rot: j sin_t in (-lim - i cos_t, ...).
    for (slope, offset) in [
        (cos_t as f64, i as f64 * sin_t as f64),
        (sin_t as f64, -(i as f64) * cos_t as f64),
    ] {
        if slope.abs() < 1e-9 {
            continue;
        }
        let (a, b) = ((-lim + offset) / slope, (lim + offset) / slope);
        lo = lo.max(a.min(b).floor() - 1.0);
        hi = hi.min(a.max(b).ceil() + 1.0);
    }
    (lo.max(-radius as f64) as i64, hi.min(radius as f64) as i64)
}

/// Compute the descriptor of one candidate from its Gaussian layer `img`; same-colour gradient
/// taps are `s` pixels apart. `sc` holds reusable buffers; `path` runs the gradient kernel.
///
/// The window is walked in two passes: the first collects the gradients and bins of the
/// samples inside the rotated grid, `kernels::polar` turns them into magnitude and
/// orientation (vectorised, bit-equal to the scalar formulas), and the second adds them to the
/// histogram in the same order as OpenCV's single loop. The Gaussian weight
/// `exp((c_rot² + r_rot²) · exp_scale)` is taken from a separable table,
/// `exp(i² a) · exp(j² a)` with `a = exp_scale / hist_width²` (the rotation keeps the norm):
/// equal up to float rounding (a few ulp of the weight), which moves a stored `u8` entry by at
/// most 1 in rare cases (measured in `docs/sift.md`).
pub(crate) fn descriptor(
    img: &Image<f32>,
    cand: &Candidate,
    s: usize,
    path: Isa,
    sc: &mut GradScratch,
) -> [u8; DESCRIPTOR_LEN] {
    let d = SIFT_DESCR_WIDTH;
    let n = SIFT_DESCR_HIST_BINS;
    let ptx = cand.ox.round() as i64;
    let pty = cand.oy.round() as i64;
    let mut ori = 360.0 - cand.kp.angle;
    if (ori - 360.0).abs() < f32::EPSILON {
        ori = 0.0;
    }
    let rad = ori * (std::f32::consts::PI / 180.0);
    let (mut sin_t, mut cos_t) = rad.sin_cos();
    let bins_per_rad = n as f32 / 360.0;
    let exp_scale = -1.0 / (d as f32 * d as f32 * 0.5);
    let hist_width = SIFT_DESCR_SCL_FCTR * cand.scl;
    let (cols, rows) = (img.width() as i64, img.height() as i64);
    let diag = ((cols * cols + rows * rows) as f64).sqrt() as i64;
    let radius = ((hist_width * std::f32::consts::SQRT_2 * (d as f32 + 1.0) * 0.5).round() as i64).min(diag);
    cos_t /= hist_width;
    sin_t /= hist_width;
    let si = s as i64;
    let a = exp_scale / (hist_width * hist_width);
    sc.clear();
    sc.table
        .extend((-radius..=radius).map(|k| ((k * k) as f32 * a).exp()));
    // Local vectors (moved back below) so that their lengths stay in registers in the loop.
    let (mut gx, mut gy) = (std::mem::take(&mut sc.dx), std::mem::take(&mut sc.dy));
    let (mut rbins, mut cbins, mut ws) = (
        std::mem::take(&mut sc.a),
        std::mem::take(&mut sc.b),
        std::mem::take(&mut sc.w),
    );
    let most = ((2 * radius + 1) * (2 * radius + 1)) as usize;
    for v in [&mut gx, &mut gy, &mut rbins, &mut cbins, &mut ws] {
        v.reserve(most);
    }
    let table = &sc.table;
    let df = d as f32;
    for i in -radius..=radius {
        let r = pty + i;
        if r < si || r >= rows - si {
            continue;
        }
        let wi = table[(i + radius) as usize];
        let ru = r as usize;
        let (above, row, below) = (img.row(ru - s), img.row(ru), img.row(ru + s));
        let fi = i as f32;
        // The exact per-sample test of OpenCV's loop. `rbin` and `cbin` are monotonic in `j`
        // (rounding is monotonic), so the samples that pass form one interval of columns: find
        // its ends from the conservative interval, then take every column in between.
        let inside = |j: i64| {
            let c_rot = j as f32 * cos_t - fi * sin_t;
            let r_rot = j as f32 * sin_t + fi * cos_t;
            let rbin = r_rot + (d / 2) as f32 - 0.5;
            let cbin = c_rot + (d / 2) as f32 - 0.5;
            rbin > -1.0 && rbin < df && cbin > -1.0 && cbin < df
        };
        let (j0, j1) = inside_columns(i, cos_t, sin_t, radius);
        let (mut ja, mut jb) = (j0.max(si - ptx), j1.min(cols - si - 1 - ptx));
        while ja <= jb && !inside(ja) {
            ja += 1;
        }
        while jb >= ja && !inside(jb) {
            jb -= 1;
        }
        if ja > jb {
            continue;
        }
        debug_assert!((ja..=jb).all(inside));
        let n = (jb - ja + 1) as usize;
        let c0 = (ptx + ja) as usize;
        // Exact-size iterators: `extend` writes in place (no zero fill first) and vectorises.
        gx.extend(
            row[c0 + s..c0 + s + n]
                .iter()
                .zip(&row[c0 - s..c0 - s + n])
                .map(|(&a, &b)| a - b),
        );
        gy.extend(
            above[c0..c0 + n]
                .iter()
                .zip(&below[c0..c0 + n])
                .map(|(&a, &b)| a - b),
        );
        let tj = &table[(ja + radius) as usize..=(jb + radius) as usize];
        ws.extend(tj.iter().map(|&t| wi * t));
        let (is, ic) = (fi * sin_t, fi * cos_t);
        let ja32 = ja as i32;
        // `j as f32` exactly (|j| < 2^24), computed in i32 so that it vectorises.
        let jf = |k: usize| (ja32 + k as i32) as f32;
        rbins.extend((0..n).map(|k| (jf(k) * sin_t + ic) + (d / 2) as f32 - 0.5));
        cbins.extend((0..n).map(|k| (jf(k) * cos_t - is) + (d / 2) as f32 - 0.5));
    }
    (sc.dx, sc.dy, sc.a, sc.b, sc.w) = (gx, gy, rbins, cbins, ws);
    sc.polar(path);
    let mut hist = [0.0f32; (SIFT_DESCR_WIDTH + 2) * (SIFT_DESCR_WIDTH + 2) * (SIFT_DESCR_HIST_BINS + 2)];
    for k in 0..sc.dx.len() {
        let (rbin, cbin) = (sc.a[k], sc.b[k]);
        let mag = sc.mag[k] * sc.w[k];
        let mut obin = (sc.ori[k] - ori) * bins_per_rad;
        let r0 = floor(rbin);
        let c0 = floor(cbin);
        let o0f = floor(obin);
        let (rb, cb) = (rbin - r0, cbin - c0);
        obin -= o0f;
        let mut o0 = o0f as i64;
        if o0 < 0 {
            o0 += n as i64;
        }
        if o0 >= n as i64 {
            o0 -= n as i64;
        }
        let v_r1 = mag * rb;
        let v_r0 = mag - v_r1;
        let v_rc11 = v_r1 * cb;
        let v_rc10 = v_r1 - v_rc11;
        let v_rc01 = v_r0 * cb;
        let v_rc00 = v_r0 - v_rc01;
        let v_rco111 = v_rc11 * obin;
        let v_rco110 = v_rc11 - v_rco111;
        let v_rco101 = v_rc10 * obin;
        let v_rco100 = v_rc10 - v_rco101;
        let v_rco011 = v_rc01 * obin;
        let v_rco010 = v_rc01 - v_rco011;
        let v_rco001 = v_rc00 * obin;
        let v_rco000 = v_rc00 - v_rco001;
        let idx = (((r0 as i64 + 1) * (d as i64 + 2) + c0 as i64 + 1) * (n as i64 + 2) + o0) as usize;
        // The eight bins touched, as one fixed-size window: a single bounds check.
        let cell: &mut [f32; SPAN] = (&mut hist[idx..idx + SPAN]).try_into().expect("SPAN bins");
        cell[0] += v_rco000;
        cell[1] += v_rco001;
        cell[n + 2] += v_rco010;
        cell[n + 3] += v_rco011;
        cell[(d + 2) * (n + 2)] += v_rco100;
        cell[(d + 2) * (n + 2) + 1] += v_rco101;
        cell[(d + 3) * (n + 2)] += v_rco110;
        cell[(d + 3) * (n + 2) + 1] += v_rco111;
    }
    let mut raw = [0.0f32; DESCRIPTOR_LEN];
    for i in 0..d {
        for j in 0..d {
            let idx = ((i + 1) * (d + 2) + (j + 1)) * (n + 2);
            hist[idx] += hist[idx + n];
            hist[idx + 1] += hist[idx + n + 1];
            raw[(i * d + j) * n..(i * d + j + 1) * n].copy_from_slice(&hist[idx..idx + n]);
        }
    }
    let nrm2: f32 = raw.iter().map(|v| v * v).sum();
    let thr = nrm2.sqrt() * SIFT_DESCR_MAG_THR;
    let mut nrm2 = 0.0f32;
    for v in raw.iter_mut() {
        *v = v.min(thr);
        nrm2 += *v * *v;
    }
    let scale = SIFT_INT_DESCR_FCTR / nrm2.sqrt().max(f32::EPSILON);
    let mut out = [0u8; DESCRIPTOR_LEN];
    for (o, v) in out.iter_mut().zip(raw) {
        *o = (v * scale).round().clamp(0.0, 255.0) as u8;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inside_columns_keep_every_sample_of_the_grid() {
        let d = SIFT_DESCR_WIDTH as f32;
        for (k, hist_width) in [(0, 4.0f32), (1, 9.6), (2, 25.0)] {
            let radius = (hist_width * std::f32::consts::SQRT_2 * (d + 1.0) * 0.5).round() as i64;
            for step in 0..720 {
                let ang = (step as f32 * 0.5 + k as f32 * 0.1).to_radians();
                let (sin_t, cos_t) = (ang.sin() / hist_width, ang.cos() / hist_width);
                for i in -radius..=radius {
                    let (j0, j1) = inside_columns(i, cos_t, sin_t, radius);
                    for j in -radius..=radius {
                        let c_rot = j as f32 * cos_t - i as f32 * sin_t;
                        let r_rot = j as f32 * sin_t + i as f32 * cos_t;
                        let rbin = r_rot + (d / 2.0) - 0.5;
                        let cbin = c_rot + (d / 2.0) - 0.5;
                        if rbin > -1.0 && rbin < d && cbin > -1.0 && cbin < d {
                            assert!((j0..=j1).contains(&j), "{ang} {i} {j}: {j0}..={j1}");
                        }
                    }
                }
            }
        }
    }
}
