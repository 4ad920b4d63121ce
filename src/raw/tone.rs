//! How a raw frame's values become the detector's mosaic: [`MosaicTone`].
//!
//! HOG reads a mosaic in 8-bit units ([`crate::features::hog::HogInput::Mosaic`]). Two tones are defined, per
//! CFA site, with `l = clamp((v − black) / (white − black), 0, 1)` (black of the site's tile
//! position, `v` the raw value):
//!
//! ```text
//! linear:  out = 255 · (v − black) / (white − black), clamped at 0 only
//!                                                        (mosaic_from_raw; every model before this)
//! srgb:    out = 255 · srgb(min(l · gain[c], 1))          c = the site's colour; gains divided by
//!                                                        the smallest if it is below 1
//! srgb(w) = 12.92 w                    (w ≤ 0.0031308)
//!         = 1.055 w^(1/2.4) − 0.055    (otherwise)
//! ```
//!
//! `srgb` is the forward ISP's per-pixel stages (black level, white balance, highlight clip, sRGB
//! transfer curve: `isp::forward` steps 1, 2 and 5) applied to each site on its own. It does not
//! demosaic, mix colours (no colour matrix) or look at neighbours, so the mosaic stays a mosaic and
//! same-colour derivatives stay same-colour. What it changes is the scale of the derivatives: in a
//! linear raw frame red and blue are 1.4–3.2 times darker than green before white balance (so
//! their sites vote with that much less weight in every HOG cell), and edges in the shadows are
//! weak against those in highlights; a model trained on sRGB images, or through an ISP, saw
//! balanced, tone-compressed values. Measured (docs/detection.md, "The mosaic's tone"): a mosaic
//! model trained through the reverse ISP misses 3.8 points fewer people at 1e-4 FPPW with `srgb`,
//! cross-validated over five folds.
//!
//! The gains come from the caller ([`crate::raw::levels::Gains`]: the frame's own, fixed, or a
//! grey-world estimate). The tone is applied through a table per tile position indexed by the raw
//! value, so the cost per pixel is one lookup; a table costs `max_value + 1` evaluations per tile
//! position (4096 for 12-bit: 0.22 ms; 65 536 for 16-bit: 3.6 ms, one thread; `benches/detect.rs`). The daemon's stage
//! keeps its tables while [`ToneTables::built_for`] holds, so they are rebuilt only when a frame's
//! levels, bit depth or gains change (every frame with grey-world gains).
//!
//! Deviation: the paper feeds the raw mosaic to HOG as it is (linear, not white balanced); `linear`
//! is that, and stays the default for every model file without a `mosaic_tone` field and for
//! OpenCV's imported weights (which do better with `srgb` on clean frames and worse under noise).

use rayon::prelude::*;

use super::levels::{Compression, Gains, NormaliseOptions};
use super::{Cfa, Colour, Levels, RawError, RawFrame, RawView};
use crate::image::Image;
use crate::srgb::srgb_from_linear;

/// Full scale of the mosaic (8-bit units, as OpenCV's HOG).
const UNIT_RANGE: f32 = 255.0;

/// How raw values are mapped before the detector's HOG (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MosaicTone {
    /// Black-subtracted and scaled to 0..=255, nothing else (the paper's raw mosaic).
    #[default]
    Linear,
    /// White balanced per site, clipped at white and sRGB-encoded, 0..=255.
    Srgb,
}

impl MosaicTone {
    /// The name in model files, configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Linear => "linear",
            Self::Srgb => "srgb",
        }
    }

    /// Whether this tone uses white-balance gains.
    pub fn uses_gains(self) -> bool {
        self == Self::Srgb
    }

    /// The `[r, g, b]` gains this tone applies to `frame` with gains from `gains` (`[1, 1, 1]`
    /// for [`MosaicTone::Linear`], which ignores them). An error for invalid fixed gains or
    /// [`Gains::FromFile`] on a frame without any.
    pub fn gains_for(self, frame: &RawFrame, gains: Gains) -> Result<[f32; 3], RawError> {
        // fixed gains are checked whatever the tone, as the config checks them
        let spec = NormaliseOptions {
            gains,
            compression: Compression::None,
        }
        .build()?;
        if !self.uses_gains() {
            return Ok([1.0; 3]);
        }
        spec.gains_for(frame)
    }
}

impl std::str::FromStr for MosaicTone {
    type Err = String;
    /// `linear` or `srgb` (the names of [`MosaicTone::name`]).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        [Self::Linear, Self::Srgb]
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| format!("'{s}' is not one of: linear, srgb"))
    }
}

/// Per-tile-position lookup tables from raw value to toned mosaic value.
#[derive(Debug, Clone, PartialEq)]
pub struct ToneTables {
    tables: [Vec<f32>; 4],
    key: ToneKey,
}

/// What a [`ToneTables`] was built from: equal keys build equal tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct ToneKey {
    levels: Levels,
    cfa: Cfa,
    max_value: u16,
    tone: MosaicTone,
    gains: [u32; 3],
}

impl ToneKey {
    fn new(frame: &RawFrame, tone: MosaicTone, gains: [f32; 3]) -> Self {
        Self {
            levels: *frame.levels(),
            cfa: frame.cfa(),
            max_value: frame.max_value(),
            tone,
            // linear ignores the gains; compared as bit patterns (equal bits build equal tables;
            // -0.0 against 0.0 only costs a rebuild)
            gains: match tone {
                MosaicTone::Linear => [0; 3],
                MosaicTone::Srgb => gains.map(f32::to_bits),
            },
        }
    }
}

impl ToneTables {
    /// Tables for `frame`'s levels and CFA, `tone` and `gains` (`[r, g, b]`; ignored by
    /// [`MosaicTone::Linear`]). Srgb divides the gains by the smallest when it is below 1 (a
    /// grey-world estimate on a reddish scene), so white stays white at every site, as with a
    /// camera's gains (green 1, the others above). Values above `max_value` (impossible in a valid
    /// frame), and for srgb above white (all clipped to the same value), read the last entry.
    pub fn new(frame: &RawFrame, tone: MosaicTone, gains: [f32; 3]) -> Self {
        let key = ToneKey::new(frame, tone, gains);
        let levels = *frame.levels();
        let n = match tone {
            MosaicTone::Linear => frame.max_value() as usize + 1,
            MosaicTone::Srgb => levels.white.min(frame.max_value()) as usize + 1,
        };
        let least = gains.iter().copied().fold(f32::INFINITY, f32::min);
        let gains = if least < 1.0 {
            gains.map(|g| g / least)
        } else {
            gains
        };
        let tables = std::array::from_fn(|p| {
            let (x, y) = (p & 1, p >> 1);
            let gain = match tone {
                MosaicTone::Linear => 1.0,
                MosaicTone::Srgb => match frame.cfa().colour_at(x, y) {
                    Colour::Red => gains[0],
                    Colour::Green => gains[1],
                    Colour::Blue => gains[2],
                },
            };
            let black = levels.black[p] as f32;
            let range = levels.white.saturating_sub(levels.black[p]).max(1) as f32;
            (0..n)
                .map(|v| match tone {
                    // the formula of `mosaic_from_raw` (bit-identical values)
                    MosaicTone::Linear => ((v as f32 - black) * (UNIT_RANGE / range)).max(0.0),
                    MosaicTone::Srgb => {
                        let l = ((v as f32 - black) / range).clamp(0.0, 1.0);
                        UNIT_RANGE * srgb_from_linear((l * gain).min(1.0))
                    }
                })
                .collect()
        });
        Self { tables, key }
    }

    /// Whether these tables are the ones [`ToneTables::new`] builds for `frame` (its levels, CFA
    /// and bit depth), `tone` and `gains`: a caller keeps them while that holds (a camera's levels
    /// and fixed or recorded gains do not change between frames).
    pub fn built_for(&self, frame: &RawFrame, tone: MosaicTone, gains: [f32; 3]) -> bool {
        self.key == ToneKey::new(frame, tone, gains)
    }

    /// Map `frame` into `dst` (resized to `width · height`), parallel over strips of `strip_rows`
    /// rows (`strip_rows ≥ 1`); the result does not depend on the strip size or thread count.
    pub fn apply_into(&self, frame: &RawFrame, strip_rows: usize, dst: &mut Vec<f32>) {
        let (w, h) = (frame.width(), frame.height());
        dst.resize(w * h, 0.0);
        if w == 0 || h == 0 {
            return;
        }
        let view = frame.view();
        let rows = strip_rows.max(1);
        dst.par_chunks_mut(rows * w).enumerate().for_each(|(s, chunk)| {
            for (r, row) in chunk.chunks_mut(w).enumerate() {
                let y = s * rows + r;
                let t = [&self.tables[(y & 1) * 2][..], &self.tables[(y & 1) * 2 + 1][..]];
                match view {
                    RawView::U8(v) => table_row(v.row(y), row, t),
                    RawView::U16(v) => table_row(v.row(y), row, t),
                }
            }
        });
    }
}

/// One row of [`ToneTables::apply_into`]: even columns read `t[0]`, odd ones `t[1]` (values past
/// a table's end read its last entry). Pairs of columns, so no per-pixel table select.
fn table_row<T: Copy + Into<usize>>(src: &[T], dst: &mut [f32], t: [&[f32]; 2]) {
    let last = [t[0].len() - 1, t[1].len() - 1];
    let at = |k: usize, p: T| t[k][p.into().min(last[k])];
    for (o, p) in dst.chunks_exact_mut(2).zip(src.chunks_exact(2)) {
        o[0] = at(0, p[0]);
        o[1] = at(1, p[1]);
    }
    if dst.len() % 2 == 1 {
        let x = dst.len() - 1;
        dst[x] = at(0, src[x]);
    }
}

/// A raw frame as a float mosaic in 8-bit units: `(v − black(x,y)) · 255 / (white − black(x,y))`,
/// clamped at 0. This is the [`crate::features::hog::HogInput::Mosaic`] domain.
pub fn mosaic_from_raw(frame: &RawFrame) -> Image<f32> {
    let mut v = Vec::new();
    mosaic_from_raw_into(frame, 16, &mut v);
    Image::from_vec(frame.width(), frame.height(), v).expect("sized by mosaic_from_raw_into")
}

/// [`mosaic_from_raw`] into a reused buffer (resized to `width · height`), parallel over strips of
/// `strip_rows` rows (`≥ 1`); the values do not depend on the strip size or thread count. Each
/// row's sample type is matched once, so the pixel loop is a plain map the compiler vectorises.
pub fn mosaic_from_raw_into(frame: &RawFrame, strip_rows: usize, dst: &mut Vec<f32>) {
    let (w, h) = (frame.width(), frame.height());
    dst.resize(w * h, 0.0);
    if w == 0 || h == 0 {
        return;
    }
    let levels = *frame.levels();
    let mut scale = [0.0f32; 4];
    for (i, s) in scale.iter_mut().enumerate() {
        *s = UNIT_RANGE / levels.white.saturating_sub(levels.black[i]).max(1) as f32;
    }
    let view = frame.view();
    let rows = strip_rows.max(1);
    dst.par_chunks_mut(rows * w).enumerate().for_each(|(s, chunk)| {
        for (r, row) in chunk.chunks_mut(w).enumerate() {
            let y = s * rows + r;
            let i = (y & 1) * 2;
            let black = [levels.black[i] as f32, levels.black[i + 1] as f32];
            let scale = [scale[i], scale[i + 1]];
            match view {
                RawView::U8(v) => linear_row(v.row(y), row, black, scale),
                RawView::U16(v) => linear_row(v.row(y), row, black, scale),
            }
        }
    });
}

/// One row of [`mosaic_from_raw_into`]: even and odd columns take their tile position's black and
/// scale.
fn linear_row<T: Copy + Into<f32>>(src: &[T], dst: &mut [f32], black: [f32; 2], scale: [f32; 2]) {
    for (o, p) in dst.chunks_exact_mut(2).zip(src.chunks_exact(2)) {
        o[0] = ((p[0].into() - black[0]) * scale[0]).max(0.0);
        o[1] = ((p[1].into() - black[1]) * scale[1]).max(0.0);
    }
    if dst.len() % 2 == 1 {
        let x = dst.len() - 1;
        dst[x] = ((src[x].into() - black[0]) * scale[0]).max(0.0);
    }
}

/// `frame` as the detector's mosaic in `tone` with white-balance `gains` (`[r, g, b]`, used by
/// [`MosaicTone::Srgb`] only). [`MosaicTone::Linear`] equals [`mosaic_from_raw`].
pub fn mosaic_from_raw_toned(frame: &RawFrame, tone: MosaicTone, gains: [f32; 3]) -> Image<f32> {
    let mut v = Vec::new();
    mosaic_from_raw_toned_into(frame, tone, gains, 16, &mut v);
    Image::from_vec(frame.width(), frame.height(), v).expect("sized by mosaic_from_raw_toned_into")
}

/// [`mosaic_from_raw_toned`] into a reused buffer, parallel over strips of `strip_rows` rows:
/// [`mosaic_from_raw_into`] for [`MosaicTone::Linear`], tables built for this frame
/// otherwise (a caller that sees many frames with the same levels and gains can keep a
/// [`ToneTables`] instead, as the daemon's stage does).
pub fn mosaic_from_raw_toned_into(
    frame: &RawFrame,
    tone: MosaicTone,
    gains: [f32; 3],
    strip_rows: usize,
    dst: &mut Vec<f32>,
) {
    match tone {
        MosaicTone::Linear => mosaic_from_raw_into(frame, strip_rows, dst),
        _ => ToneTables::new(frame, tone, gains).apply_into(frame, strip_rows, dst),
    }
}

/// [`mosaic_from_raw_toned`] with the gains resolved from `gains` ([`MosaicTone::gains_for`]).
pub fn mosaic_from_raw_with(
    frame: &RawFrame,
    tone: MosaicTone,
    gains: Gains,
) -> Result<Image<f32>, RawError> {
    Ok(mosaic_from_raw_toned(frame, tone, tone.gains_for(frame, gains)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mosaic_from_raw_is_the_per_site_formula_for_any_strip_size() {
        use crate::raw::{Cfa, Levels};
        // 12-bit with a black level per tile position, even width; 8-bit with an odd width
        let px: Vec<u16> = (0..32 * 20u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 20) as u16 & 4095)
            .collect();
        let levels16 = Levels {
            black: [60, 64, 62, 66],
            white: 4000,
        };
        let f16 = RawFrame::from_u16(32, 20, px, Cfa::Gbrg, 12, levels16).unwrap();
        let px8: Vec<u8> = (0..31 * 21u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 24) as u8)
            .collect();
        let levels8 = Levels {
            black: [16, 12, 14, 10],
            white: 250,
        };
        let f8 = RawFrame::from_u8(31, 21, px8, Cfa::Rggb, levels8).unwrap();
        for f in [&f16, &f8] {
            let l = *f.levels();
            let want: Vec<f32> = (0..f.height())
                .flat_map(|y| (0..f.width()).map(move |x| (x, y)))
                .map(|(x, y)| {
                    let i = (y & 1) * 2 + (x & 1);
                    let scale = 255.0 / (l.white - l.black[i]) as f32;
                    ((f.value(x, y) as f32 - l.black[i] as f32) * scale).max(0.0)
                })
                .collect();
            assert!(want.contains(&0.0) && want.iter().any(|&v| v > 200.0));
            // the form this function had before (clamped before the scale) gives the same bits
            let clamp_first: Vec<f32> = (0..f.height())
                .flat_map(|y| (0..f.width()).map(move |x| (x, y)))
                .map(|(x, y)| {
                    let i = (y & 1) * 2 + (x & 1);
                    let scale = 255.0 / (l.white - l.black[i]) as f32;
                    (f.value(x, y) as f32 - l.black[i] as f32).max(0.0) * scale
                })
                .collect();
            assert_eq!(clamp_first, want);
            assert_eq!(mosaic_from_raw(f).as_slice(), want.as_slice());
            let mut got = vec![7.0; 3];
            for strip in [1, 2, 3, 8, 64] {
                mosaic_from_raw_into(f, strip, &mut got);
                assert_eq!(got, want, "strip {strip}");
            }
        }
    }

    fn frame() -> RawFrame {
        // 12-bit, black 256, white 4095; RGGB
        let px: Vec<u16> = (0..64u16).map(|i| 200 + i * 61).collect();
        RawFrame::from_u16(8, 8, px, Cfa::Rggb, 12, Levels::uniform(256, 4095)).unwrap()
    }

    #[test]
    fn tables_are_built_for_one_set_of_levels_cfa_bit_depth_tone_and_gains() {
        let f = frame();
        let g = [2.0, 1.0, 3.0];
        let t = ToneTables::new(&f, MosaicTone::Srgb, g);
        assert!(t.built_for(&f, MosaicTone::Srgb, g));
        assert!(!t.built_for(&f, MosaicTone::Srgb, [2.0, 1.0, 3.5]), "gains");
        assert!(!t.built_for(&f, MosaicTone::Linear, g), "tone");
        let px: Vec<u16> = (0..64u16).map(|i| 200 + i * 61).collect();
        let other = |cfa, bits, levels| RawFrame::from_u16(8, 8, px.clone(), cfa, bits, levels).unwrap();
        let l = Levels::uniform(256, 4095);
        assert!(
            t.built_for(&other(Cfa::Rggb, 12, l), MosaicTone::Srgb, g),
            "same inputs"
        );
        assert!(!t.built_for(&other(Cfa::Gbrg, 12, l), MosaicTone::Srgb, g), "CFA");
        assert!(
            !t.built_for(&other(Cfa::Rggb, 14, l), MosaicTone::Srgb, g),
            "bit depth"
        );
        assert!(
            !t.built_for(
                &other(Cfa::Rggb, 12, Levels::uniform(240, 4095)),
                MosaicTone::Srgb,
                g
            ),
            "black"
        );
        assert!(
            !t.built_for(
                &other(Cfa::Rggb, 12, Levels::uniform(256, 4000)),
                MosaicTone::Srgb,
                g
            ),
            "white"
        );
        // linear tables do not depend on the gains
        let lin = ToneTables::new(&f, MosaicTone::Linear, g);
        assert!(lin.built_for(&f, MosaicTone::Linear, [1.0; 3]));
    }

    #[test]
    fn linear_tables_equal_mosaic_from_raw() {
        let f = frame();
        let mut v = Vec::new();
        ToneTables::new(&f, MosaicTone::Linear, [2.0, 1.0, 3.0]).apply_into(&f, 3, &mut v);
        assert_eq!(v, super::mosaic_from_raw(&f).into_vec());
    }

    #[test]
    fn srgb_applies_the_gain_of_each_sites_colour_then_the_curve() {
        let f = frame();
        let gains = [2.0, 1.0, 3.0];
        let m = mosaic_from_raw_toned(&f, MosaicTone::Srgb, gains);
        for y in 0..8 {
            for x in 0..8 {
                let l = ((f.value(x, y) as f32 - 256.0) / (4095.0 - 256.0)).clamp(0.0, 1.0);
                let g = match (x & 1, y & 1) {
                    (0, 0) => 2.0,
                    (1, 1) => 3.0,
                    _ => 1.0,
                };
                let w = (l * g).min(1.0);
                let want = 255.0 * srgb_from_linear(w);
                assert!(
                    (m.get(x, y) - want).abs() < 1e-4,
                    "({x}, {y}): {} vs {want}",
                    m.get(x, y)
                );
            }
        }
        // black maps to 0, white (and anything a gain pushes past it) to 255
        assert_eq!(m.get(0, 0), 0.0);
        assert!((m.get(7, 7) - 255.0).abs() < 1e-3, "{}", m.get(7, 7));
    }

    #[test]
    fn values_above_white_clip_and_gains_below_one_keep_white_white() {
        // 12-bit, white 3000 < max 4095: values 3000..=4095 all read white in srgb
        let px: Vec<u16> = (0..16u16)
            .map(|i| [100, 2000, 3000, 4095][i as usize % 4])
            .collect();
        let f = RawFrame::from_u16(4, 4, px, Cfa::Rggb, 12, Levels::uniform(100, 3000)).unwrap();
        let m = mosaic_from_raw_toned(&f, MosaicTone::Srgb, [0.5, 1.0, 2.0]);
        // gains become [1, 2, 4]: every site at or above white is 255, black is 0
        for y in 0..4 {
            for x in 0..4 {
                let v = f.value(x, y);
                let got = m.get(x, y);
                if v >= 3000 {
                    assert!((got - 255.0).abs() < 1e-3, "({x}, {y}) {v}: {got}");
                } else if v == 100 {
                    assert_eq!(got, 0.0);
                }
            }
        }
        // green (1, 0) at 2000 with gain 1 / 0.5 = 2: l = 1900/2900 · 2 > 1, clipped; with unit
        // gains it is the curve of l
        assert!((m.get(1, 0) - 255.0).abs() < 1e-3, "{}", m.get(1, 0));
        let unit = mosaic_from_raw_toned(&f, MosaicTone::Srgb, [1.0; 3]);
        let want = 255.0 * srgb_from_linear(1900.0 / 2900.0);
        assert!((unit.get(1, 0) - want).abs() < 1e-3, "{}", unit.get(1, 0));
        // linear keeps values above white above 255 (as mosaic_from_raw does)
        let lin = mosaic_from_raw_toned(&f, MosaicTone::Linear, [1.0; 3]);
        assert!(lin.get(3, 0) > 255.0);
    }

    #[test]
    fn strips_do_not_change_the_result() {
        let f = frame();
        let t = ToneTables::new(&f, MosaicTone::Srgb, [1.5, 1.0, 2.5]);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        t.apply_into(&f, 1, &mut a);
        t.apply_into(&f, 5, &mut b);
        assert_eq!(a, b);
    }

    #[test]
    fn gains_come_from_the_frame_or_grey_world_and_file_gains_must_exist() {
        let f = frame();
        assert_eq!(
            MosaicTone::Linear.gains_for(&f, Gains::FromFile).unwrap(),
            [1.0; 3]
        );
        let e = MosaicTone::Srgb.gains_for(&f, Gains::FromFile).unwrap_err();
        assert!(matches!(e, RawError::NoFileGains { .. }), "{e}");
        let g = f.clone().with_wb_gains([1.5, 1.0, 2.5]);
        assert_eq!(
            MosaicTone::Srgb.gains_for(&g, Gains::Auto).unwrap(),
            [1.5, 1.0, 2.5]
        );
        assert_eq!(
            MosaicTone::Srgb.gains_for(&f, Gains::Auto).unwrap(),
            crate::raw::levels::grey_world_gains(&f)
        );
        assert!(MosaicTone::Srgb
            .gains_for(&f, Gains::Fixed([0.0, 1.0, 1.0]))
            .is_err());
        assert!(MosaicTone::Linear
            .gains_for(&f, Gains::Fixed([0.0, 1.0, 1.0]))
            .is_err());
        // a file's gains out of range: auto falls back to grey world, file refuses them
        let wild = f.clone().with_wb_gains([20.0, 1.0, 1.0]);
        assert_eq!(
            MosaicTone::Srgb.gains_for(&wild, Gains::Auto).unwrap(),
            crate::raw::levels::grey_world_gains(&f)
        );
        assert!(MosaicTone::Srgb.gains_for(&wild, Gains::FromFile).is_err());
    }

    #[test]
    fn names_parse_back_and_serde_agrees() {
        for t in [MosaicTone::Linear, MosaicTone::Srgb] {
            assert_eq!(t.name().parse::<MosaicTone>().unwrap(), t);
            assert_eq!(serde_json::to_string(&t).unwrap(), format!("\"{}\"", t.name()));
        }
        assert!("gamma"
            .parse::<MosaicTone>()
            .unwrap_err()
            .contains("linear, srgb"));
    }
}
