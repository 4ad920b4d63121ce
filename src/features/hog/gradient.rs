//! Gradients of gamma-corrected planes and their orientation votes, one pixel row at a time
//! (steps 2 and 3 of the math in the parent module).

use super::types::{Planes, RowScratch};
use super::CELL_SIZE;
use crate::image::ImageView;

/// OpenCV's `fastAtan32f` in degrees, [0, 360) (branch-free so it vectorises).
#[inline(always)]
pub fn fast_atan2_deg(y: f32, x: f32) -> f32 {
    // Polynomial constants of OpenCV mathfuncs_core (atan2_p1..p7), in degrees.
    const DEG: f32 = (180.0 / std::f64::consts::PI) as f32;
    const P1: f32 = 0.999_787_84_f32 * DEG;
    const P3: f32 = -0.325_808_4_f32 * DEG;
    const P5: f32 = 0.155_578_65_f32 * DEG;
    const P7: f32 = -0.044_326_555_f32 * DEG;
    const EPS: f32 = f64::EPSILON as f32;
    let (ax, ay) = (x.abs(), y.abs());
    // ax >= ay: c = ay/(ax+eps); else c = ax/(ay+eps) — both are min/(max+eps).
    let c = ax.min(ay) / (ax.max(ay) + EPS);
    let c2 = c * c;
    let p = (((P7 * c2 + P5) * c2 + P3) * c2 + P1) * c;
    let a = if ax >= ay { p } else { 90.0 - p };
    let a = if x < 0.0 { 180.0 - a } else { a };
    if y < 0.0 {
        360.0 - a
    } else {
        a
    }
}

/// `BORDER_REFLECT_101` index (for `n > tap`).
#[inline]
pub(super) fn reflect101(i: isize, n: usize) -> usize {
    let n = n as isize;
    let r = if i < 0 {
        -i
    } else if i >= n {
        2 * n - 2 - i
    } else {
        i
    };
    r.clamp(0, n - 1) as usize
}

/// Derivatives of one plane's row `y` into `dx`, `dy` (reflect-101 at the borders).
#[inline(always)]
fn derivatives(
    plane: ImageView<'_, f32>,
    tap: usize,
    y: usize,
    ym: usize,
    yp: usize,
    dx: &mut [f32],
    dy: &mut [f32],
) {
    let w = plane.width();
    let r = plane.row(y);
    let (rm, rp) = (plane.row(ym), plane.row(yp));
    for ((d, a), b) in dy.iter_mut().zip(rp).zip(rm) {
        *d = a - b;
    }
    if w > 2 * tap {
        for ((d, a), b) in dx[tap..w - tap].iter_mut().zip(&r[2 * tap..]).zip(r) {
            *d = a - b;
        }
    }
    let t = tap as isize;
    for x in (0..tap.min(w)).chain(w.saturating_sub(tap).max(tap.min(w))..w) {
        dx[x] = r[reflect101(x as isize + t, w)] - r[reflect101(x as isize - t, w)];
    }
}

/// One row of quantised gradients: two bins and two weights per pixel (OpenCV `qangle`, `grad`).
#[inline(always)]
pub(super) fn gradient_row(
    p: &Planes,
    y: usize,
    nbins: usize,
    sc: &mut RowScratch,
    bins: &mut [[u8; 2]],
    wts: &mut [[f32; 2]],
) {
    let w = p.width;
    let t = p.tap as isize;
    let ym = reflect101(y as isize - t, p.height);
    let yp = reflect101(y as isize + t, p.height);
    let n = bins.len().min(w);
    derivatives(p.planes[0], p.tap, y, ym, yp, &mut sc.dx, &mut sc.dy);
    if p.planes.len() > 1 {
        // OpenCV colour rule: a later plane (B, G, R order) wins only when strictly larger.
        for (d, (a, b)) in sc.m.iter_mut().zip(sc.dx.iter().zip(&sc.dy)) {
            *d = a * a + b * b;
        }
        let mut dx2 = vec![0.0f32; w];
        let mut dy2 = vec![0.0f32; w];
        for plane in &p.planes[1..] {
            derivatives(*plane, p.tap, y, ym, yp, &mut dx2, &mut dy2);
            for x in 0..w {
                let m = dx2[x] * dx2[x] + dy2[x] * dy2[x];
                if m > sc.m[x] {
                    sc.m[x] = m;
                    sc.dx[x] = dx2[x];
                    sc.dy[x] = dy2[x];
                }
            }
        }
    }
    if p.tap == 2 {
        // Same-colour taps are two pixels apart: halve to keep the [-1,0,1] scale.
        sc.dx.iter_mut().for_each(|v| *v *= 0.5);
        sc.dy.iter_mut().for_each(|v| *v *= 0.5);
    }
    let angle_scale = (nbins as f64 / std::f64::consts::PI) as f32;
    let to_rad = (std::f64::consts::PI / 180.0) as f32;
    let nb = nbins as i32;
    // Vectorisable pass: magnitude into dx, bin coordinate into dy.
    for (dx, dy) in sc.dx[..n].iter_mut().zip(&mut sc.dy[..n]) {
        let (gx, gy) = (*dx, *dy);
        *dx = (gx * gx + gy * gy).sqrt();
        *dy = fast_atan2_deg(gy, gx) * to_rad * angle_scale - 0.5;
    }
    for x in 0..n {
        let (mag, ang) = (sc.dx[x], sc.dy[x]);
        let hf = ang.floor();
        let frac = ang - hf;
        let mut h = hf as i32;
        if h < 0 {
            h += nb;
        } else if h >= nb {
            h -= nb;
        }
        let h = h.clamp(0, nb - 1);
        let h1 = if h + 1 < nb { h + 1 } else { 0 };
        bins[x] = [h as u8, h1 as u8];
        wts[x] = [mag * (1.0 - frac), mag * frac];
    }
}

/// Gradients and orientation bins of every pixel row the cells use, as the cell stage computes
/// them (each row's results marked as read, so the pass is not optimised away).
#[inline(always)]
pub(super) fn gradient_pass(p: &Planes, nb: usize) {
    let w8 = p.width / CELL_SIZE * CELL_SIZE;
    let mut sc = RowScratch::new(p.width);
    let mut bins = vec![[0u8; 2]; w8];
    let mut wts = vec![[0.0f32; 2]; w8];
    for y in 0..p.height / CELL_SIZE * CELL_SIZE {
        gradient_row(p, y, nb, &mut sc, &mut bins, &mut wts);
        // The row's results count as read, at no cost.
        std::hint::black_box((&bins, &wts));
    }
}
