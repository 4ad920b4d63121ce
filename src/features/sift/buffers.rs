//! Recycled pixel buffers for the SIFT pyramid.
//!
//! A 1080p mosaic pyramid holds about 25 full-size `f32` images (Gaussian and DoG layers, the
//! blur's scratch image). Allocating them fresh for every frame costs a page fault per 4 KiB
//! page and a kernel page clear, which measured more than the blurs themselves (`docs/sift.md`,
//! "Speed"). Buffers are therefore returned here when a pyramid is dropped and handed out again
//! to the next one. A buffer taken from the pool keeps its old contents: every user overwrites
//! all pixels (the blur, the DoG and the input copy write each one), so nothing stale is read
//! and results do not depend on what ran before (the determinism tests run frames of
//! different sizes one after the other).
//!
//! The pool holds at most [`MAX_POOLED`] buffers; with frames of one size it keeps what one
//! pyramid needs (about 110 MB for a 1920x1080 mosaic) for the life of the process.

use std::sync::Mutex;

use crate::image::Image;

/// Most buffers kept for reuse (one 1080p pyramid needs about 25 large ones).
const MAX_POOLED: usize = 64;

static POOL: Mutex<Vec<Vec<f32>>> = Mutex::new(Vec::new());

/// A `width` x `height` image whose contents are unspecified: the caller must write every pixel
/// before reading any. Reuses the smallest pooled buffer that is large enough.
pub(crate) fn take(width: usize, height: usize) -> Image<f32> {
    let n = width * height;
    let reused = {
        let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
        let best = pool
            .iter()
            .enumerate()
            .filter(|(_, b)| b.capacity() >= n)
            .min_by_key(|(_, b)| b.capacity())
            .map(|(i, _)| i);
        best.map(|i| pool.swap_remove(i))
    };
    let mut buf = reused.unwrap_or_default();
    if buf.len() >= n {
        buf.truncate(n);
    } else {
        buf.resize(n, 0.0);
    }
    Image::from_vec(width, height, buf).expect("buffer holds width * height pixels")
}

/// Give an image's buffer back for reuse.
pub(crate) fn give(img: Image<f32>) {
    let buf = img.into_vec();
    if buf.capacity() == 0 {
        return;
    }
    let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
    if pool.len() < MAX_POOLED {
        pool.push(buf);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taken_images_have_the_asked_size_and_reuse_buffers() {
        let mut a = take(40, 30);
        assert_eq!(a.dimensions(), (40, 30));
        a.as_mut_slice().fill(7.0);
        give(a);
        let b = take(20, 10);
        assert_eq!(b.dimensions(), (20, 10));
        assert_eq!(b.as_slice().len(), 200);
        give(b);
        let c = take(50, 50);
        assert_eq!(c.as_slice().len(), 2500);
        give(c);
    }
}
