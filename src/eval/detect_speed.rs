//! The timed loop of `mosaicd bench detect`: a HOG or ACF detector ([`PeopleDetector`]) on one raw
//! frame, the daemon's way, repeated after one warm-up frame.
//!
//! Each frame is brought into the model's tone in a reused `f32` buffer (`auto` gains: the frame's
//! own, else a grey-world estimate; the sRGB tables are rebuilt every frame here, where the daemon
//! keeps them while the gains stay the same, so the sRGB tone is timed pessimistically) and handed,
//! with its CFA, to the detector on the current rayon pool. A frame's time is that whole call.

use std::time::{Duration, Instant};

use super::detection::{DetEvalError, Result};
use crate::detect::people::{PeopleDetector, PeopleInput, PeopleStats};
use crate::image::ImageView;
use crate::raw::levels::Gains;
use crate::raw::tone::mosaic_from_raw_toned_into;
use crate::raw::RawFrame;

/// One timed frame.
#[derive(Debug, Clone)]
pub struct TimedFrame {
    /// Bringing the raw frame into the model's tone.
    pub normalise: Duration,
    /// The whole frame: tone and detection.
    pub total: Duration,
    /// Boxes after suppression.
    pub boxes: usize,
    /// The detector's statistics.
    pub stats: PeopleStats,
}

/// Time `det` on `frame` for `frames` frames after one warm-up frame (not returned), with
/// `gains` for the sRGB tone and `strip_rows` rows per parallel strip of the tone mapping;
/// `step(i)` is called before frame `i` (0 = the warm-up).
pub fn time_detector(
    det: &PeopleDetector,
    frame: &RawFrame,
    gains: Gains,
    strip_rows: usize,
    frames: usize,
    step: &mut dyn FnMut(usize),
) -> Result<Vec<TimedFrame>> {
    let prep = det.mosaic_prep(gains);
    let mut buf = Vec::new();
    let mut out = Vec::with_capacity(frames);
    for i in 0..=frames {
        step(i);
        let t0 = Instant::now();
        let g = prep.gains_for(frame).map_err(DetEvalError::Raw)?;
        mosaic_from_raw_toned_into(frame, prep.tone, g, strip_rows, &mut buf);
        let image = ImageView::new(&buf, frame.width(), frame.height(), frame.width())
            .map_err(DetEvalError::Image)?;
        let normalise = t0.elapsed();
        let (b, stats) = det.detect(&PeopleInput::Mosaic {
            image,
            cfa: frame.cfa(),
        })?;
        let total = t0.elapsed();
        if i > 0 {
            out.push(TimedFrame {
                normalise,
                total,
                boxes: b.len(),
                stats,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::{Cfa, Levels};

    #[test]
    fn every_timed_frame_is_the_detectors_own_result() {
        let det = crate::detect::people::every_window_acf();
        let (w, h) = (100, 164);
        let px: Vec<u16> = (0..w * h)
            .map(|i| (300 + (i % w) * 17 + (i / w) * 5 + (i % 7) * 90) as u16 % 4000)
            .collect();
        let f = RawFrame::from_u16(w, h, px, Cfa::Bggr, 12, Levels::uniform(32, 4095)).unwrap();
        let mut seen = Vec::new();
        let t = time_detector(&det, &f, Gains::Auto, 8, 3, &mut |i| seen.push(i)).unwrap();
        assert_eq!(seen, [0, 1, 2, 3], "a warm-up and three timed frames");
        assert_eq!(t.len(), 3);
        // the model's srgb tone with grey-world gains (the frame has none), the frame's CFA
        let m = det.mosaic_prep(Gains::Auto).mosaic(&f).unwrap();
        let (want, st) = det
            .detect(&PeopleInput::Mosaic {
                image: m.view(),
                cfa: Cfa::Bggr,
            })
            .unwrap();
        assert!(!want.is_empty());
        for tf in &t {
            assert_eq!((tf.boxes, tf.stats.windows()), (want.len(), st.windows()));
            assert!(tf.total >= tf.normalise);
        }
    }
}
