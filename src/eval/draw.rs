//! Drawing on pictures for the experiments' figures and `mosaicd detect --preview`: detection boxes,
//! keypoint crosses, lines, grey planes.

use crate::features::sift::SiftFeatures;
use crate::geometry::Detection;
use crate::image::Image;

/// Draw box outlines (2 px, green) on an RGB image.
pub fn draw_boxes(img: &mut Image<[u8; 3]>, dets: &[Detection]) {
    let (w, h) = img.dimensions();
    for d in dets {
        let x0 = d.x.max(0.0) as usize;
        let y0 = d.y.max(0.0) as usize;
        let x1 = ((d.x + d.width) as usize).min(w.saturating_sub(1));
        let y1 = ((d.y + d.height) as usize).min(h.saturating_sub(1));
        for t in 0..2 {
            for x in x0..=x1 {
                for y in [y0 + t, y1.saturating_sub(t)] {
                    if y < h && x < w {
                        img.set(x, y, [0, 255, 0]);
                    }
                }
            }
            for y in y0..=y1 {
                for x in [x0 + t, x1.saturating_sub(t)] {
                    if y < h && x < w {
                        img.set(x, y, [0, 255, 0]);
                    }
                }
            }
        }
    }
}

/// Paint a grey plane (8-bit units, clamped) into `canvas` with its left edge at column `ox`.
pub fn paint_grey(canvas: &mut image::RgbImage, img: &Image<f32>, ox: usize) {
    for y in 0..img.height() {
        for x in 0..img.width() {
            let v = img.get(x, y).clamp(0.0, 255.0) as u8;
            canvas.put_pixel((x + ox) as u32, y as u32, image::Rgb([v, v, v]));
        }
    }
}

/// Draw each keypoint as a small yellow cross.
pub fn draw_keypoints(canvas: &mut image::RgbImage, f: &SiftFeatures, ox: usize) {
    for k in &f.keypoints {
        let (x, y) = (k.x as f64 + ox as f64, k.y as f64);
        let r = (k.size as f64 * 0.5).clamp(2.0, 12.0);
        let c = image::Rgb([255, 220, 0]);
        draw_line(canvas, (x - r, y), (x + r, y), c);
        draw_line(canvas, (x, y - r), (x, y + r), c);
    }
}

/// Straight line by uniform sampling (clipped to the canvas).
pub fn draw_line(canvas: &mut image::RgbImage, a: (f64, f64), b: (f64, f64), c: image::Rgb<u8>) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        if x >= 0.0 && y >= 0.0 && (x as u32) < canvas.width() && (y as u32) < canvas.height() {
            canvas.put_pixel(x as u32, y as u32, c);
        }
    }
}
