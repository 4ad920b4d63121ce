//! One small owned image type and borrowed views over it.
//!
//! [`Image<P>`] owns a contiguous row-major buffer (`stride == width`). [`ImageView<P>`] and
//! [`ImageViewMut<P>`] borrow a rectangle with an arbitrary row stride, so a crop or a V4L2 buffer
//! with padding can be read without copying. Kernels take views; allocating wrappers return images.
//! `P` is a plain pixel type: `u8`, `u16`, `f32`, or `[T; 3]` for RGB.
//!
//! ```
//! use mosaicd::image::Image;
//! let mut img = Image::<u16>::new(4, 2);
//! img.set(3, 1, 7);
//! assert_eq!(img.get(3, 1), 7);
//! assert_eq!(img.view().row(1), &[0, 0, 0, 7]);
//! let crop = img.view().crop(2, 1, 2, 1).unwrap();
//! assert_eq!(crop.row(0), &[0, 7]);
//! ```

use thiserror::Error;

/// Errors from building images and views.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ImageError {
    /// The buffer does not hold `stride * (height - 1) + width` pixels.
    #[error(
        "buffer of {len} pixels is too small for {width}x{height} with stride {stride} (needs {needed})"
    )]
    BufferSize {
        /// Pixels in the buffer.
        len: usize,
        /// Requested width.
        width: usize,
        /// Requested height.
        height: usize,
        /// Requested stride in pixels.
        stride: usize,
        /// Pixels needed.
        needed: usize,
    },
    /// The stride is smaller than the width.
    #[error("stride {stride} is smaller than width {width}")]
    Stride {
        /// Requested stride.
        stride: usize,
        /// Requested width.
        width: usize,
    },
    /// A crop rectangle reaches outside the image.
    #[error("crop {w}x{h} at ({x}, {y}) does not fit in {width}x{height}")]
    Crop {
        /// Crop x.
        x: usize,
        /// Crop y.
        y: usize,
        /// Crop width.
        w: usize,
        /// Crop height.
        h: usize,
        /// Image width.
        width: usize,
        /// Image height.
        height: usize,
    },
}

fn needed(width: usize, height: usize, stride: usize) -> usize {
    if width == 0 || height == 0 {
        0
    } else {
        stride * (height - 1) + width
    }
}

/// An owned, contiguous, row-major image.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Image<P> {
    width: usize,
    height: usize,
    data: Vec<P>,
}

impl<P: Copy + Default> Image<P> {
    /// A `width` x `height` image filled with `P::default()`.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: vec![P::default(); width * height],
        }
    }

    /// A `width` x `height` image filled with `value`.
    pub fn filled(width: usize, height: usize, value: P) -> Self {
        Self {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// Resize in place to `width` x `height` (contents unspecified afterwards), reusing the
    /// allocation when it is large enough. Used by pooled buffers.
    pub fn reshape(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        self.data.resize(width * height, P::default());
    }
}

impl<P: Copy> Image<P> {
    /// Wrap a buffer of exactly `width * height` pixels.
    pub fn from_vec(width: usize, height: usize, data: Vec<P>) -> Result<Self, ImageError> {
        if data.len() != width * height {
            return Err(ImageError::BufferSize {
                len: data.len(),
                width,
                height,
                stride: width,
                needed: width * height,
            });
        }
        Ok(Self { width, height, data })
    }

    /// Build an image by evaluating `f(x, y)` at every pixel.
    pub fn from_fn(width: usize, height: usize, mut f: impl FnMut(usize, usize) -> P) -> Self {
        let mut data = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        Self { width, height, data }
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// `(width, height)`.
    #[inline]
    pub fn dimensions(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The pixels, row-major.
    #[inline]
    pub fn as_slice(&self) -> &[P] {
        &self.data
    }

    /// The pixels, row-major, mutable.
    #[inline]
    pub fn as_mut_slice(&mut self) -> &mut [P] {
        &mut self.data
    }

    /// Give up the buffer.
    pub fn into_vec(self) -> Vec<P> {
        self.data
    }

    /// Pixel at (x, y). Panics when out of bounds (like slice indexing).
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> P {
        self.data[y * self.width + x]
    }

    /// Set the pixel at (x, y). Panics when out of bounds.
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, v: P) {
        self.data[y * self.width + x] = v;
    }

    /// Row `y`.
    #[inline]
    pub fn row(&self, y: usize) -> &[P] {
        &self.data[y * self.width..(y + 1) * self.width]
    }

    /// Row `y`, mutable.
    #[inline]
    pub fn row_mut(&mut self, y: usize) -> &mut [P] {
        let w = self.width;
        &mut self.data[y * w..(y + 1) * w]
    }

    /// Borrow the whole image as a view.
    #[inline]
    pub fn view(&self) -> ImageView<'_, P> {
        ImageView {
            width: self.width,
            height: self.height,
            stride: self.width,
            data: &self.data,
        }
    }

    /// Borrow the whole image as a mutable view.
    #[inline]
    pub fn view_mut(&mut self) -> ImageViewMut<'_, P> {
        ImageViewMut {
            width: self.width,
            height: self.height,
            stride: self.width,
            data: &mut self.data,
        }
    }

    /// Apply `f` to every pixel, producing a new image.
    pub fn map<Q: Copy>(&self, f: impl FnMut(P) -> Q) -> Image<Q> {
        Image {
            width: self.width,
            height: self.height,
            data: self.data.iter().copied().map(f).collect(),
        }
    }
}

/// A borrowed rectangle of pixels with a row stride (in pixels).
#[derive(Debug, Clone, Copy)]
pub struct ImageView<'a, P> {
    width: usize,
    height: usize,
    stride: usize,
    data: &'a [P],
}

impl<'a, P: Copy> ImageView<'a, P> {
    /// View `data` as `width` x `height` with `stride` pixels between row starts.
    pub fn new(data: &'a [P], width: usize, height: usize, stride: usize) -> Result<Self, ImageError> {
        if stride < width {
            return Err(ImageError::Stride { stride, width });
        }
        let n = needed(width, height, stride);
        if data.len() < n {
            return Err(ImageError::BufferSize {
                len: data.len(),
                width,
                height,
                stride,
                needed: n,
            });
        }
        Ok(Self {
            width,
            height,
            stride,
            data,
        })
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// Pixels between the starts of consecutive rows.
    #[inline]
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// The underlying slice (from the first pixel, `stride` apart).
    #[inline]
    pub fn as_slice(&self) -> &'a [P] {
        self.data
    }

    /// Row `y` (`width` pixels).
    #[inline]
    pub fn row(&self, y: usize) -> &'a [P] {
        let s = y * self.stride;
        &self.data[s..s + self.width]
    }

    /// Pixel at (x, y).
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> P {
        self.data[y * self.stride + x]
    }

    /// A sub-rectangle; errors when it does not fit.
    pub fn crop(&self, x: usize, y: usize, w: usize, h: usize) -> Result<ImageView<'a, P>, ImageError> {
        if x + w > self.width || y + h > self.height {
            return Err(ImageError::Crop {
                x,
                y,
                w,
                h,
                width: self.width,
                height: self.height,
            });
        }
        if w == 0 || h == 0 {
            return Ok(ImageView {
                width: w,
                height: h,
                stride: self.stride,
                data: &[],
            });
        }
        let start = y * self.stride + x;
        let end = start + needed(w, h, self.stride);
        Ok(ImageView {
            width: w,
            height: h,
            stride: self.stride,
            data: &self.data[start..end],
        })
    }

    /// Copy into a contiguous owned image.
    pub fn to_image(&self) -> Image<P> {
        let mut data = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            data.extend_from_slice(self.row(y));
        }
        Image {
            width: self.width,
            height: self.height,
            data,
        }
    }
}

/// A mutable borrowed rectangle of pixels with a row stride (in pixels).
#[derive(Debug)]
pub struct ImageViewMut<'a, P> {
    width: usize,
    height: usize,
    stride: usize,
    data: &'a mut [P],
}

impl<'a, P: Copy> ImageViewMut<'a, P> {
    /// View `data` mutably as `width` x `height` with `stride`.
    pub fn new(data: &'a mut [P], width: usize, height: usize, stride: usize) -> Result<Self, ImageError> {
        if stride < width {
            return Err(ImageError::Stride { stride, width });
        }
        let n = needed(width, height, stride);
        if data.len() < n {
            return Err(ImageError::BufferSize {
                len: data.len(),
                width,
                height,
                stride,
                needed: n,
            });
        }
        Ok(Self {
            width,
            height,
            stride,
            data,
        })
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// Pixels between row starts.
    #[inline]
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Row `y`, mutable.
    #[inline]
    pub fn row_mut(&mut self, y: usize) -> &mut [P] {
        let s = y * self.stride;
        &mut self.data[s..s + self.width]
    }

    /// Set the pixel at (x, y).
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, v: P) {
        self.data[y * self.stride + x] = v;
    }

    /// The underlying mutable slice.
    #[inline]
    pub fn as_mut_slice(&mut self) -> &mut [P] {
        self.data
    }

    /// Reborrow as a read-only view.
    pub fn as_view(&self) -> ImageView<'_, P> {
        ImageView {
            width: self.width,
            height: self.height,
            stride: self.stride,
            data: self.data,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_rejects_short_buffer_and_bad_stride() {
        let buf = [0u8; 10];
        assert!(matches!(
            ImageView::new(&buf, 4, 3, 4),
            Err(ImageError::BufferSize { .. })
        ));
        assert!(matches!(
            ImageView::new(&buf, 4, 2, 3),
            Err(ImageError::Stride { .. })
        ));
        // stride*(h-1)+w = 5*1+4 = 9 fits in 10
        assert!(ImageView::new(&buf, 4, 2, 5).is_ok());
    }

    #[test]
    fn crop_and_rows() {
        let img = Image::from_fn(5, 4, |x, y| (y * 10 + x) as u16);
        let c = img.view().crop(1, 2, 3, 2).unwrap();
        assert_eq!(c.row(0), &[21, 22, 23]);
        assert_eq!(c.row(1), &[31, 32, 33]);
        assert_eq!(c.to_image().as_slice(), &[21, 22, 23, 31, 32, 33]);
        assert!(img.view().crop(3, 0, 3, 1).is_err());
    }
}
