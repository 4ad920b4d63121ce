//! Gaussian scale space for SIFT on a grey image (`step = 1`) or on a Bayer mosaic (`step = 2`).
//!
//! Every operation here works on an interleaved image whose same-colour samples are `step` pixels
//! apart. With `step = 1` they are the plain OpenCV operations SIFT uses (`GaussianBlur` with
//! `BORDER_REFLECT_101`, `resize` x2 with `INTER_LINEAR`, `resize` /2 with `INTER_NEAREST`); with
//! `step = 2` the same operation is applied to each of the four colour planes of the mosaic
//! (the paper's 2x2 super-pixel), and the result stays a valid mosaic of the same pattern. Kernel
//! sigmas passed here are in **plane** pixels: a mosaic-pixel sigma `s` is `s / 2` on a plane.
//!
//! The pyramid uses `features::superpixel` (`gaussian_blur` / `blur_mosaic`, `downsample2` /
//! `downsample2_mosaic`) and the crate's one resize ([`crate::resize`]: `resize_bilinear` /
//! `resize_mosaic`) through [`blur_step`], [`upsample2_step`] and [`downsample2_step`]. The
//! plain-slice kernels below (one code path for both steps) were the stand-in before those
//! modules landed; they stay as the test oracle the shared functions are checked against.

use rayon::prelude::*;

use super::kernels;
use crate::features::superpixel::{
    blur_mosaic, downsample2 as sp_downsample2, downsample2_mosaic, gaussian_blur, GaussianKernel,
    SuperPixelError,
};
use crate::image::Image;
use crate::kernels::Isa;

/// Gaussian blur with plane sigma `sigma` of a grey image (`step = 1`) or a mosaic (`step = 2`).
pub(crate) fn blur_step(
    src: &Image<f32>,
    sigma: f64,
    step: usize,
    dst: &mut Image<f32>,
) -> Result<(), SuperPixelError> {
    blur_step_with(
        src,
        sigma,
        step,
        dst,
        &mut Image::new(0, 0),
        None,
        crate::kernels::isa(),
    )
}

/// [`blur_step`] with a reusable scratch image and an explicit kernel path (the pyramid reuses
/// one scratch image for all its blurs). With `dog`, also writes the difference of Gaussians
/// `dog = dst - src` (reshaped; fused into the blur's last pass on the symmetric path).
pub(crate) fn blur_step_with(
    src: &Image<f32>,
    sigma: f64,
    step: usize,
    dst: &mut Image<f32>,
    tmp: &mut Image<f32>,
    dog: Option<&mut Image<f32>>,
    path: Isa,
) -> Result<(), SuperPixelError> {
    let k = GaussianKernel::from_sigma(sigma)?;
    let symmetric = step != 1 && src.width().is_multiple_of(2) && src.height().is_multiple_of(2);
    if symmetric {
        blur_symmetric(src, k.taps(), step, dst, tmp, dog, path);
        return Ok(());
    }
    if step == 1 {
        gaussian_blur(src.view(), &k, dst)?;
    } else {
        blur_mosaic(src.view(), &k, dst)?;
    }
    if let Some(d) = dog {
        d.reshape(src.width(), src.height());
        for ((o, &b), &a) in d
            .as_mut_slice()
            .iter_mut()
            .zip(dst.as_slice())
            .zip(src.as_slice())
        {
            *o = b - a;
        }
    }
    Ok(())
}

/// Rows handed to one rayon task by [`blur_symmetric`].
const SYM_ROW_STRIP: usize = 16;

/// Separable blur of a `step`-interleaved image with a symmetric kernel, reflect-101 inside each
/// plane, without splitting the planes: taps are `step` pixels apart and mirrored pairs are added
/// before multiplying. Equals `blur_mosaic` (checked against the oracle kernel in the tests) and
/// avoids its four plane copies and re-interleaving per layer. `tmp` holds the horizontal pass
/// (reused between calls); the interior runs through the [`kernels`] of `path`, bit-equal on
/// every path. With `dog`, each output row's difference `dst - src` is written there by the
/// vertical kernel from its registers (the SIFT pyramid's DoG layer, without another pass over
/// memory). The reflected border taps of the horizontal pass come from one index table per call
/// (the same for every row).
pub(crate) fn blur_symmetric(
    src: &Image<f32>,
    taps: &[f32],
    step: usize,
    dst: &mut Image<f32>,
    tmp: &mut Image<f32>,
    dog: Option<&mut Image<f32>>,
    path: Isa,
) {
    let (w, h) = src.dimensions();
    dst.reshape(w, h);
    tmp.reshape(w, h);
    if w == 0 || h == 0 {
        return;
    }
    let r = taps.len() / 2;
    let reach = r * step;
    let interior = if w > 2 * reach { reach..w - reach } else { 0..0 };
    // Border pixels only (reflected taps): the two ends, or the whole row when the kernel is
    // wider than it. Their reflected source columns are the same on every row: one table.
    let (left, right) = if interior.is_empty() {
        (w, w)
    } else {
        (reach, w - reach)
    };
    let border: Vec<usize> = (0..left).chain(right..w).collect();
    let border_src: Vec<usize> = border
        .iter()
        .flat_map(|&x| {
            let p = x % step;
            let j = (x / step) as isize;
            let n = (w + step - 1 - p) / step;
            (0..taps.len()).map(move |k| reflect(j + k as isize - r as isize, n) * step + p)
        })
        .collect();
    tmp.as_mut_slice()
        .par_chunks_mut(w * SYM_ROW_STRIP)
        .enumerate()
        .for_each(|(si, strip)| {
            for (ri, out) in strip.chunks_mut(w).enumerate() {
                let row = src.row(si * SYM_ROW_STRIP + ri);
                if !interior.is_empty() {
                    kernels::blur_row_interior(path, row, taps, step, reach, w - reach, out);
                }
                for (&x, cols) in border.iter().zip(border_src.chunks_exact(taps.len())) {
                    let mut acc = 0.0f32;
                    for (&t, &c) in taps.iter().zip(cols) {
                        acc += t * row[c];
                    }
                    out[x] = acc;
                }
            }
        });
    let tmp = &*tmp;
    // Output row `y` from the `r` reflected rows above and below it; with `dog`, also the
    // difference to the source row written by the same kernel.
    let vertical_row = |y: usize, out: &mut [f32], dog: Option<&mut [f32]>| {
        let p = y % step;
        let j = (y / step) as isize;
        let n = (h + step - 1 - p) / step;
        let row_at = |k: isize| tmp.row(reflect(j + k, n) * step + p);
        let mut up = [&[][..]; MAX_STACK_RADIUS];
        let mut down = [&[][..]; MAX_STACK_RADIUS];
        let mut heap: (Vec<&[f32]>, Vec<&[f32]>);
        let (up, down): (&[&[f32]], &[&[f32]]) = if r <= MAX_STACK_RADIUS {
            for k in 1..=r {
                up[k - 1] = row_at(-(k as isize));
                down[k - 1] = row_at(k as isize);
            }
            (&up[..r], &down[..r])
        } else {
            heap = (Vec::with_capacity(r), Vec::with_capacity(r));
            for k in 1..=r as isize {
                heap.0.push(row_at(-k));
                heap.1.push(row_at(k));
            }
            (&heap.0, &heap.1)
        };
        match dog {
            Some(d) => kernels::blur_col_dog(path, row_at(0), up, down, taps, src.row(y), out, d),
            None => kernels::blur_col(path, row_at(0), up, down, taps, out),
        }
    };
    match dog {
        Some(d) => {
            d.reshape(w, h);
            dst.as_mut_slice()
                .par_chunks_mut(w * SYM_ROW_STRIP)
                .zip(d.as_mut_slice().par_chunks_mut(w * SYM_ROW_STRIP))
                .enumerate()
                .for_each(|(si, (strip, ds))| {
                    for (ri, (out, dr)) in strip.chunks_mut(w).zip(ds.chunks_mut(w)).enumerate() {
                        vertical_row(si * SYM_ROW_STRIP + ri, out, Some(dr));
                    }
                });
        }
        None => dst
            .as_mut_slice()
            .par_chunks_mut(w * SYM_ROW_STRIP)
            .enumerate()
            .for_each(|(si, strip)| {
                for (ri, out) in strip.chunks_mut(w).enumerate() {
                    vertical_row(si * SYM_ROW_STRIP + ri, out, None);
                }
            }),
    }
}

/// Kernel radius up to which the vertical pass keeps its row list on the stack (plane sigma
/// below about 3.9; larger kernels use a heap list).
const MAX_STACK_RADIUS: usize = 16;

#[cfg(test)]
/// [`blur_symmetric`] as it was before the kernels (whole-row multiply-adds per tap): the
/// reference the kernel version must equal bit for bit.
pub(crate) fn blur_symmetric_reference(src: &Image<f32>, taps: &[f32], step: usize, dst: &mut Image<f32>) {
    let (w, h) = src.dimensions();
    dst.reshape(w, h);
    if w == 0 || h == 0 {
        return;
    }
    let r = taps.len() / 2;
    let reach = r * step;
    let mut tmp = Image::<f32>::new(w, h);
    for (y, out) in tmp.as_mut_slice().chunks_mut(w).enumerate() {
        let row = src.row(y);
        if w > 2 * reach {
            let (lo, hi) = (reach, w - reach);
            for (o, &v) in out[lo..hi].iter_mut().zip(&row[lo..hi]) {
                *o = taps[r] * v;
            }
            for k in 1..=r {
                let t = taps[r + k];
                let a = &row[lo - k * step..hi - k * step];
                let b = &row[lo + k * step..hi + k * step];
                for ((o, &va), &vb) in out[lo..hi].iter_mut().zip(a).zip(b) {
                    *o += t * (va + vb);
                }
            }
        }
        for (x, o) in out.iter_mut().enumerate() {
            if x >= reach && x + reach < w {
                continue;
            }
            let p = x % step;
            let j = (x / step) as isize;
            let n = (w + step - 1 - p) / step;
            let mut acc = 0.0f32;
            for (k, &t) in taps.iter().enumerate() {
                acc += t * row[reflect(j + k as isize - r as isize, n) * step + p];
            }
            *o = acc;
        }
    }
    for (y, out) in dst.as_mut_slice().chunks_mut(w).enumerate() {
        let p = y % step;
        let j = (y / step) as isize;
        let n = (h + step - 1 - p) / step;
        let row_at = |k: isize| tmp.row(reflect(j + k, n) * step + p);
        for (o, &v) in out.iter_mut().zip(row_at(0)) {
            *o = taps[r] * v;
        }
        for k in 1..=r {
            let t = taps[r + k];
            let (a, b) = (row_at(-(k as isize)), row_at(k as isize));
            for ((o, &va), &vb) in out.iter_mut().zip(a).zip(b) {
                *o += t * (va + vb);
            }
        }
    }
}

/// `BORDER_REFLECT_101` index into a plane of `n` samples.
#[inline]
fn reflect(mut i: isize, n: usize) -> usize {
    let n = n as isize;
    if n == 1 {
        return 0;
    }
    loop {
        if i < 0 {
            i = -i;
        } else if i >= n {
            i = 2 * n - 2 - i;
        } else {
            return i as usize;
        }
    }
}

/// x2 bilinear upsampling of the image or of every colour plane.
pub(crate) fn upsample2_step(
    src: &Image<f32>,
    step: usize,
) -> Result<Image<f32>, crate::resize::ResizeError> {
    let mut dst = Image::new(0, 0);
    let (w, h) = src.dimensions();
    if step == 1 {
        crate::resize::resize_bilinear(src.view(), 2 * w, 2 * h, &mut dst)?;
    } else {
        crate::resize::resize_mosaic(src.view(), 2 * w, 2 * h, &mut dst)?;
    }
    Ok(dst)
}

#[cfg(test)]
/// The octave step: every other pixel, or every other super-pixel.
pub(crate) fn downsample2_step(src: &Image<f32>, step: usize) -> Result<Image<f32>, SuperPixelError> {
    let mut dst = Image::new(0, 0);
    downsample2_step_into(src, step, false, &mut dst)?;
    Ok(dst)
}

/// [`downsample2_step`] into `dst` (reshaped; every pixel written); with `centred`, the mean of
/// each 2x2 block of same-colour samples instead ([`downsample2_centred_into`]).
pub(crate) fn downsample2_step_into(
    src: &Image<f32>,
    step: usize,
    centred: bool,
    dst: &mut Image<f32>,
) -> Result<(), SuperPixelError> {
    if centred {
        downsample2_centred_into(src, step, dst)
    } else if step == 1 {
        sp_downsample2(src.view(), dst)
    } else {
        downsample2_mosaic(src.view(), dst)
    }
}

/// The centred octave step: output sample `i` (per colour plane for `step = 2`) is the mean of
/// the same-colour samples `2i` and `2i + 1` of its plane in both directions, so it sits at plane
/// position `2i + 0.5`. Every input sample of a `2 * step`-aligned region is used once: the grid
/// is symmetric under flips and quarter turns when the plane sides are even, which picking every
/// other sample is not. Sizes as [`downsample2_step`]; needs at least `2 * step` pixels each way.
pub(crate) fn downsample2_centred_into(
    src: &Image<f32>,
    step: usize,
    dst: &mut Image<f32>,
) -> Result<(), SuperPixelError> {
    let (w, h) = src.dimensions();
    let (ow, oh) = (step * ((w / step) / 2), step * ((h / step) / 2));
    if ow == 0 || oh == 0 {
        return Err(SuperPixelError::TooSmall {
            what: "octave step input",
            width: w,
            height: h,
            min_width: 2 * step,
            min_height: 2 * step,
        });
    }
    dst.reshape(ow, oh);
    // Output column x takes input columns 2x - p and 2x - p + step, p = x % step (its phase).
    let map = |x: usize| 2 * x - x % step;
    for y in 0..oh {
        let (r0, r1) = (src.row(map(y)), src.row(map(y) + step));
        let o = dst.row_mut(y);
        for (x, v) in o.iter_mut().enumerate() {
            let (a, b) = (map(x), map(x) + step);
            *v = ((r0[a] + r0[b]) + (r1[a] + r1[b])) * 0.25;
        }
    }
    Ok(())
}

/// Rows handed to one rayon task by the separable blur.
#[cfg(test)]
const BLUR_ROW_STRIP: usize = 16;

#[cfg(test)]
/// OpenCV's Gaussian kernel for floating-point images: `ksize = round(8 sigma + 1) | 1` taps of
/// `exp(-x^2 / (2 sigma^2))`, normalised to sum 1 (computed in f64, stored as f32).
pub(crate) fn gaussian_taps(sigma: f64) -> Vec<f32> {
    /// OpenCV's kernel half-width in sigmas for non-8-bit images (`cvRound(sigma*4*2+1)|1`).
    const TRUNCATE_SIGMAS: f64 = 4.0;
    let ksize = (((sigma * TRUNCATE_SIGMAS * 2.0 + 1.0).round() as i64) | 1).max(1) as usize;
    let c = (ksize as f64 - 1.0) * 0.5;
    let scale = -0.5 / (sigma * sigma);
    let raw: Vec<f64> = (0..ksize)
        .map(|i| {
            let x = i as f64 - c;
            (scale * x * x).exp()
        })
        .collect();
    let sum: f64 = raw.iter().sum();
    raw.iter().map(|v| (v / sum) as f32).collect()
}

#[cfg(test)]
/// `BORDER_REFLECT_101` index into a plane of `n` samples (`n >= 1`).
#[inline]
pub(crate) fn reflect101(mut i: isize, n: usize) -> usize {
    let n = n as isize;
    if n == 1 {
        return 0;
    }
    loop {
        if i < 0 {
            i = -i;
        } else if i >= n {
            i = 2 * n - 2 - i;
        } else {
            return i as usize;
        }
    }
}

#[cfg(test)]
/// Number of samples of phase `p` in a line of `len` pixels with same-colour step `step`.
#[inline]
fn plane_len(len: usize, step: usize, p: usize) -> usize {
    (len + step - 1 - p) / step
}

#[cfg(test)]
/// Blur one line: `dst[x] = sum_k taps[k] * src[same-colour neighbour k - r of x]`.
fn blur_line(src: &[f32], taps: &[f32], step: usize, dst: &mut [f32]) {
    let len = src.len();
    let r = taps.len() / 2;
    let reach = r * step;
    for (x, d) in dst.iter_mut().enumerate() {
        let mut acc = 0.0f32;
        if x >= reach && x + reach < len {
            let base = x - reach;
            for (k, &t) in taps.iter().enumerate() {
                acc += t * src[base + k * step];
            }
        } else {
            let p = x % step;
            let j = (x / step) as isize;
            let n = plane_len(len, step, p);
            for (k, &t) in taps.iter().enumerate() {
                let jj = reflect101(j + k as isize - r as isize, n);
                acc += t * src[jj * step + p];
            }
        }
        *d = acc;
    }
}

#[cfg(test)]
/// Separable Gaussian blur of a `step`-interleaved image (`step = 1`: grey, `2`: mosaic planes),
/// `BORDER_REFLECT_101` inside each plane. `src` and `dst` are `width * height`, contiguous.
pub(crate) fn blur(src: &Image<f32>, taps: &[f32], step: usize, dst: &mut Image<f32>) {
    let (w, h) = src.dimensions();
    dst.reshape(w, h);
    if w == 0 || h == 0 {
        return;
    }
    let mut tmp = Image::<f32>::new(w, h);
    tmp.as_mut_slice()
        .par_chunks_mut(w * BLUR_ROW_STRIP)
        .enumerate()
        .for_each(|(si, strip)| {
            for (ri, out) in strip.chunks_mut(w).enumerate() {
                blur_line(src.row(si * BLUR_ROW_STRIP + ri), taps, step, out);
            }
        });
    let r = taps.len() / 2;
    let tmp = &tmp;
    dst.as_mut_slice()
        .par_chunks_mut(w * BLUR_ROW_STRIP)
        .enumerate()
        .for_each(|(si, strip)| {
            for (ri, out) in strip.chunks_mut(w).enumerate() {
                let y = si * BLUR_ROW_STRIP + ri;
                let p = y % step;
                let j = (y / step) as isize;
                let n = plane_len(h, step, p);
                out.iter_mut().for_each(|v| *v = 0.0);
                for (k, &t) in taps.iter().enumerate() {
                    let yy = reflect101(j + k as isize - r as isize, n) * step + p;
                    for (o, &s) in out.iter_mut().zip(tmp.row(yy)) {
                        *o += t * s;
                    }
                }
            }
        });
}

#[cfg(test)]
/// Bilinear x2 upsampling of every plane (OpenCV `INTER_LINEAR`, half-pixel centres, replicated
/// border): output is `2 * width` x `2 * height`.
pub(crate) fn upsample2(src: &Image<f32>, step: usize) -> Image<f32> {
    let (w, h) = src.dimensions();
    let (ow, oh) = (w * 2, h * 2);
    // For output plane index j the source plane coordinate is j / 2 - 0.25.
    let coord = |j: usize, n: usize| -> (usize, usize, f32) {
        let s = j as f32 * 0.5 - 0.25;
        let mut i0 = s.floor() as isize;
        let mut f = s - i0 as f32;
        if i0 < 0 {
            i0 = 0;
            f = 0.0;
        }
        let i0 = i0 as usize;
        if i0 + 1 >= n {
            (n - 1, n - 1, 0.0)
        } else {
            (i0, i0 + 1, f)
        }
    };
    let xs: Vec<(usize, usize, f32)> = (0..ow)
        .map(|x| {
            let p = x % step;
            let (a, b, f) = coord(x / step, plane_len(w, step, p));
            (a * step + p, b * step + p, f)
        })
        .collect();
    let mut out = Image::<f32>::new(ow, oh);
    out.as_mut_slice()
        .par_chunks_mut(ow)
        .enumerate()
        .for_each(|(y, row)| {
            let p = y % step;
            let (a, b, fy) = coord(y / step, plane_len(h, step, p));
            let (ra, rb) = (src.row(a * step + p), src.row(b * step + p));
            for (o, &(x0, x1, fx)) in row.iter_mut().zip(&xs) {
                let top = ra[x0] * (1.0 - fx) + ra[x1] * fx;
                let bot = rb[x0] * (1.0 - fx) + rb[x1] * fx;
                *o = top * (1.0 - fy) + bot * fy;
            }
        });
    out
}

#[cfg(test)]
/// Keep every other same-colour sample (SIFT's octave step; OpenCV `INTER_NEAREST` to half size
/// for `step = 1`, every other super-pixel for `step = 2`).
pub(crate) fn downsample2(src: &Image<f32>, step: usize) -> Image<f32> {
    let (w, h) = src.dimensions();
    let ow = step * ((w / step) / 2);
    let oh = step * ((h / step) / 2);
    let map = |x: usize| 2 * x - x % step;
    Image::from_fn(ow, oh, |x, y| src.get(map(x), map(y)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_match_opencv_rule() {
        // sigma 1.6: ksize = round(13.8) | 1 = 15 (odd already: 14 | 1 = 15).
        let t = gaussian_taps(1.6);
        assert_eq!(t.len(), 15);
        let s: f32 = t.iter().sum();
        assert!((s - 1.0).abs() < 1e-6);
        assert!((t[7] - t[7].max(t[6])).abs() < 1e-9);
        assert_eq!(t[0], t[14]);
    }

    #[test]
    fn reflect101_by_hand() {
        assert_eq!(reflect101(-1, 5), 1);
        assert_eq!(reflect101(-2, 5), 2);
        assert_eq!(reflect101(5, 5), 3);
        assert_eq!(reflect101(6, 5), 2);
        assert_eq!(reflect101(-3, 2), 1);
        assert_eq!(reflect101(4, 1), 0);
    }

    #[test]
    fn blur_keeps_a_flat_image_flat_and_mosaic_planes_apart() {
        let flat = Image::filled(9, 7, 3.0f32);
        let mut out = Image::new(0, 0);
        blur(&flat, &gaussian_taps(1.2), 1, &mut out);
        assert!(out.as_slice().iter().all(|v| (v - 3.0).abs() < 1e-5));
        // A mosaic whose planes are constant (10, 20, 30, 40) stays exactly that after a mosaic blur.
        let m = Image::from_fn(12, 10, |x, y| (10 * (1 + (x % 2) + 2 * (y % 2))) as f32);
        blur(&m, &gaussian_taps(1.0), 2, &mut out);
        for y in 0..10 {
            for x in 0..12 {
                assert!((out.get(x, y) - m.get(x, y)).abs() < 1e-4, "{x},{y}");
            }
        }
    }

    #[test]
    fn blur_by_hand_on_an_impulse() {
        let mut img = Image::<f32>::new(5, 1);
        img.set(2, 0, 1.0);
        let taps = [0.25f32, 0.5, 0.25];
        let mut out = Image::new(0, 0);
        blur(&img, &taps, 1, &mut out);
        assert_eq!(out.row(0), &[0.0, 0.25, 0.5, 0.25, 0.0]);
        // Reflect-101 at the border: an impulse at x=0 sees itself mirrored at x=1.
        let mut e = Image::<f32>::new(4, 1);
        e.set(0, 0, 1.0);
        blur(&e, &taps, 1, &mut out);
        assert_eq!(out.row(0), &[0.5, 0.25, 0.0, 0.0]);
    }

    #[test]
    fn upsample_and_downsample_by_hand() {
        let img = Image::from_vec(2, 1, vec![0.0f32, 4.0]).unwrap();
        let up = upsample2(&img, 1);
        assert_eq!(up.dimensions(), (4, 2));
        assert_eq!(up.row(0), &[0.0, 1.0, 3.0, 4.0]);
        let d = downsample2(&Image::from_fn(8, 4, |x, y| (x + 10 * y) as f32), 2);
        assert_eq!(d.dimensions(), (4, 2));
        assert_eq!(d.row(0), &[0.0, 1.0, 4.0, 5.0]);
        assert_eq!(d.row(1), &[10.0, 11.0, 14.0, 15.0]);
    }

    #[test]
    fn centred_downsample_by_hand() {
        let img = Image::from_fn(8, 4, |x, y| (x + 10 * y) as f32);
        let mut d = Image::new(0, 0);
        downsample2_centred_into(&img, 2, &mut d).unwrap();
        assert_eq!(d.dimensions(), (4, 2));
        // Plane (0, 0) samples at columns 0, 2 and rows 0, 2: mean (0 + 2 + 20 + 22) / 4 = 11.
        assert_eq!(d.row(0), &[11.0, 12.0, 15.0, 16.0]);
        assert_eq!(d.row(1), &[21.0, 22.0, 25.0, 26.0]);
        downsample2_centred_into(&img, 1, &mut d).unwrap();
        assert_eq!(d.dimensions(), (4, 2));
        assert_eq!(d.row(0), &[5.5, 7.5, 9.5, 11.5]);
        assert!(downsample2_centred_into(&Image::new(3, 8), 2, &mut d).is_err());
    }

    /// A quarter turn (x, y) -> (h - 1 - y, x) of the pixel array.
    fn quarter_turn(img: &Image<f32>) -> Image<f32> {
        let (w, h) = img.dimensions();
        Image::from_fn(h, w, |x, y| img.get(y, h - 1 - x))
    }

    #[test]
    fn centred_octaves_commute_with_quarter_turns_and_picked_ones_do_not() {
        // Plane sides even: 24x16 (planes 12x8) for the mosaic, 12x8 for grey.
        for (step, w, h) in [(2, 24, 16), (1, 12, 8)] {
            let img = Image::from_fn(w, h, |x, y| {
                ((x * 7 + y * 13) % 17) as f32 + 0.25 * (x % 2) as f32
            });
            let (mut a, mut b) = (Image::new(0, 0), Image::new(0, 0));
            downsample2_centred_into(&quarter_turn(&img), step, &mut a).unwrap();
            downsample2_centred_into(&img, step, &mut b).unwrap();
            assert_eq!(a, quarter_turn(&b), "step {step}");
            // Picking every other sample: the turned image's grid is one sample off.
            assert_ne!(
                downsample2(&quarter_turn(&img), step),
                quarter_turn(&downsample2(&img, step))
            );
        }
    }

    #[test]
    fn superpixel_functions_equal_the_oracle_kernels() {
        let img = Image::from_fn(46, 38, |x, y| {
            ((x * 7 + y * 13) % 17) as f32 + 0.25 * (x % 2) as f32
        });
        for step in [1, 2] {
            for sigma in [0.6, 1.2, 2.7] {
                let mut a = Image::new(0, 0);
                blur(&img, &gaussian_taps(sigma), step, &mut a);
                let mut b = Image::new(0, 0);
                blur_step(&img, sigma, step, &mut b).unwrap();
                let mut c = Image::new(0, 0);
                let k = GaussianKernel::from_sigma(sigma).unwrap();
                if step == 1 {
                    gaussian_blur(img.view(), &k, &mut c).unwrap();
                } else {
                    blur_mosaic(img.view(), &k, &mut c).unwrap();
                }
                for (p, q) in c.as_slice().iter().zip(b.as_slice()) {
                    assert!(
                        (p - q).abs() < 1e-4,
                        "superpixel vs ours step {step} sigma {sigma}: {p} vs {q}"
                    );
                }
                for (p, q) in a.as_slice().iter().zip(b.as_slice()) {
                    assert!((p - q).abs() < 1e-4, "blur step {step} sigma {sigma}: {p} vs {q}");
                }
            }
            let (a, b) = (upsample2(&img, step), upsample2_step(&img, step).unwrap());
            assert_eq!(a.dimensions(), b.dimensions());
            for (p, q) in a.as_slice().iter().zip(b.as_slice()) {
                assert!((p - q).abs() < 1e-4, "upsample step {step}: {p} vs {q}");
            }
            assert_eq!(downsample2(&img, step), downsample2_step(&img, step).unwrap());
        }
    }

    #[test]
    fn blur_parallel_equals_serial() {
        let img = Image::from_fn(67, 53, |x, y| ((x * 7 + y * 13) % 17) as f32);
        let taps = gaussian_taps(2.0);
        let mut a = Image::new(0, 0);
        blur(&img, &taps, 2, &mut a);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let mut b = Image::new(0, 0);
        pool.install(|| blur(&img, &taps, 2, &mut b));
        assert_eq!(a, b);
        let (mut c, mut d, mut t) = (Image::new(0, 0), Image::new(0, 0), Image::new(0, 0));
        let path = crate::kernels::isa();
        blur_symmetric(&img, &taps, 2, &mut c, &mut t, None, path);
        pool.install(|| blur_symmetric(&img, &taps, 2, &mut d, &mut t, None, path));
        assert_eq!(c, d);
    }

    #[test]
    fn blur_symmetric_kernel_paths_are_bit_equal_to_its_reference() {
        // Wider than two kernel chunks, odd interior lengths, and a size where the kernel
        // reaches past the plane (reflect on both sides).
        for (w, h) in [(150, 46), (38, 30), (20, 12)] {
            let img = Image::from_fn(w, h, |x, y| {
                ((x * 7919 + y * 104_729) % 1013) as f32 * 0.37 - 80.0
            });
            for step in [1, 2] {
                for sigma in [0.7, 1.52, 3.09] {
                    let taps = gaussian_taps(sigma);
                    let mut want = Image::new(0, 0);
                    blur_symmetric_reference(&img, &taps, step, &mut want);
                    for path in Isa::available() {
                        let (mut got, mut tmp, mut dog) =
                            (Image::new(0, 0), Image::new(0, 0), Image::new(0, 0));
                        blur_symmetric(&img, &taps, step, &mut got, &mut tmp, Some(&mut dog), path);
                        for ((d, b), a) in dog.as_slice().iter().zip(want.as_slice()).zip(img.as_slice()) {
                            assert_eq!(d.to_bits(), (b - a).to_bits(), "dog {w}x{h} {step} {path:?}");
                        }
                        assert!(
                            want.as_slice()
                                .iter()
                                .zip(got.as_slice())
                                .all(|(a, b)| a.to_bits() == b.to_bits()),
                            "{w}x{h} step {step} sigma {sigma} {path:?}"
                        );
                    }
                }
            }
        }
    }
}
