//! Recording recipes: how a recording under `recordings/` is rebuilt from shared data (or from a
//! scene our own code draws), so that only the recipe is committed, never the data.
//!
//! A recipe names a still source frame — a headerless or camera raw file, or an RGB image taken
//! through the reverse ISP with a camera profile, or a synthetic scene — and a **camera motion**:
//! a `width` x `height` crop window moving along straight segments between waypoints (equal time
//! per segment, positions rounded to whole pixels). With `align = "any"` odd offsets are kept and
//! re-phase the CFA (an RGGB frame cropped at x = 1 is GRBG), which the recording stores per frame;
//! `align = "even"` rounds offsets down to even so the phase never changes. Each frame then gets
//! Poisson–Gaussian noise (`noise = "none" | "low" | "medium" | "high"`, the paper's presets) with
//! seed `seed + frame index`. Timestamps are `index · 1e9 / fps` from 0: no wall clock, so the same
//! recipe always produces the same bytes.
//!
//! ```toml
//! name = "demo"
//! output = "recordings/out/demo.mcap"
//! frames = 48
//! fps = 30.0
//! seed = 1
//! noise = "none"
//!
//! [source]
//! kind = "raw"                                   # raw | rgb | synthetic
//! file = "raw/infinite_isp_8bit/Outdoor1_2592x1536_8bit_GRBG.raw"   # under the data root
//! format = { width = 2592, height = 1536, bit_depth = 8, cfa = "GRBG", black = 12, white = 255 }
//!
//! [motion]
//! width = 1280
//! height = 720
//! waypoints = [[0, 0], [1311, 815]]
//! align = "any"
//! ```
//!
//! `kind = "rgb"` takes `file` (an sRGB PNG/JPEG/BMP under the data root) or `files` (several:
//! frame `i` shows file `i mod n`, each taken through the reverse ISP once), `profile` (a stem of
//! `config/cameras/`, default the Infinite-ISP indoor tuning), optional `cfa`, `bit_depth` and
//! `scale` (bilinear resize of the images first).
//! `kind = "synthetic"` takes `width`, `height` and the same profile keys, and draws a scene from
//! `seed` (sky gradient, ground, coloured boxes and discs, a bar chart of stripes).
//!
//! ```
//! use mosaicd::record::{crop_origin, Align};
//! // Halfway along one segment from (0,0) to (9,5), 3 frames: (0,0), (4.5→5, 2.5→3), (9,5).
//! assert_eq!(crop_origin(&[[0, 0], [9, 5]], 1, 3, Align::Any), (5, 3));
//! assert_eq!(crop_origin(&[[0, 0], [9, 5]], 1, 3, Align::Even), (4, 2));
//! ```

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Deserialize;

use super::{
    FlushPolicy, McapRecorder, PreviewOptions, RecordError, RecorderOptions, RecordingSummary, RotatePolicy,
};
use crate::capture::files::Sidecar;
use crate::image::Image;
use crate::isp::{add_noise_to_raw, raw_from_srgb, CameraProfile, NoiseLevel, ReverseIspOptions};
use crate::raw::load::{load_headerless, load_input, load_rgb8, InputOptions};
use crate::raw::{Cfa, RawFrame};

/// Crop-window alignment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Align {
    /// Any offset; odd offsets re-phase the pattern.
    #[default]
    Any,
    /// Offsets rounded down to even: the pattern never changes.
    Even,
}

/// The still frame a recipe starts from.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceSpec {
    /// `raw`, `rgb` or `synthetic`.
    pub kind: String,
    /// File under the data root (`raw`, `rgb`).
    pub file: Option<PathBuf>,
    /// Instead of `file` (`rgb`): a sequence of images under the data root; frame `i` shows image
    /// `i mod n` (a stream with motion in the scene, e.g. consecutive frames of a video).
    #[serde(default)]
    pub files: Vec<PathBuf>,
    /// Scale factor applied to RGB images before the reverse ISP (`rgb`; bilinear, default 1):
    /// a small photo as a larger sensor would see it.
    pub scale: Option<f64>,
    /// Headerless raw description (`raw`; camera raw files need none).
    pub format: Option<Sidecar>,
    /// Camera profile stem in `config/cameras/` (`rgb`, `synthetic`).
    pub profile: Option<String>,
    /// Output pattern (`rgb`, `synthetic`; default the profile's).
    pub cfa: Option<String>,
    /// Output bit depth (`rgb`, `synthetic`; default the profile's).
    pub bit_depth: Option<u8>,
    /// Scene width (`synthetic`).
    pub width: Option<usize>,
    /// Scene height (`synthetic`).
    pub height: Option<usize>,
}

/// The camera motion.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motion {
    /// Crop width.
    pub width: usize,
    /// Crop height.
    pub height: usize,
    /// Top-left corners visited in order (at least one).
    pub waypoints: Vec<[usize; 2]>,
    /// Offset alignment.
    #[serde(default)]
    pub align: Align,
}

/// Recorder settings of a recipe.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecipeRecorder {
    /// Preview decimation (0 = no preview).
    #[serde(default = "default_decimation")]
    pub preview_decimation: u32,
    /// Flush every N frames.
    #[serde(default = "default_flush")]
    pub flush_frames: u32,
    /// zstd level (default [`super::recorder::DEFAULT_COMPRESSION_LEVEL`]; 3 compresses
    /// overlapping crops of 8-bit frames about 2x better, at about 4x the time).
    #[serde(default = "default_level")]
    pub compression_level: u32,
    /// Start a new file after this many MiB (none by default; 0 = never).
    #[serde(default)]
    pub rotate_mb: Option<u64>,
    /// Start a new file after this many seconds of recorded time (none by default; 0 = never).
    #[serde(default)]
    pub rotate_secs: Option<u64>,
}

fn default_decimation() -> u32 {
    2
}
fn default_level() -> u32 {
    super::recorder::DEFAULT_COMPRESSION_LEVEL
}
fn default_flush() -> u32 {
    super::recorder::DEFAULT_FLUSH_FRAMES
}

impl Default for RecipeRecorder {
    fn default() -> Self {
        Self {
            preview_decimation: default_decimation(),
            flush_frames: default_flush(),
            compression_level: default_level(),
            rotate_mb: None,
            rotate_secs: None,
        }
    }
}

/// A recording recipe.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recipe {
    /// Name.
    pub name: String,
    /// Output file (relative paths are relative to the working directory).
    pub output: PathBuf,
    /// Frames to record.
    pub frames: u64,
    /// Frame rate for timestamps.
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Seed (noise, synthetic scene).
    #[serde(default)]
    pub seed: u64,
    /// `none`, `low`, `medium`, `high`.
    #[serde(default = "default_noise")]
    pub noise: String,
    /// Camera name (topic prefix).
    #[serde(default = "default_camera")]
    pub camera: String,
    /// The still frame.
    pub source: SourceSpec,
    /// The motion.
    pub motion: Motion,
    /// Recorder settings.
    #[serde(default)]
    pub recorder: RecipeRecorder,
}

fn default_fps() -> f64 {
    30.0
}
fn default_noise() -> String {
    "none".into()
}
fn default_camera() -> String {
    "camera".into()
}

/// Errors building a recording from a recipe.
#[derive(Debug, thiserror::Error)]
pub enum RecipeError {
    /// The recipe file cannot be read.
    #[error("cannot read recipe {path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// The recipe does not parse.
    #[error("recipe {path} does not parse: {source}")]
    Syntax {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: Box<toml::de::Error>,
    },
    /// A value is out of range.
    #[error("recipe key {key} = {value} is invalid: expected {why}")]
    Value {
        /// Key.
        key: &'static str,
        /// Value.
        value: String,
        /// Allowed values.
        why: &'static str,
    },
    /// The source frame cannot be loaded.
    #[error("recipe source: {0}")]
    Source(#[from] crate::raw::RawError),
    /// A source description (sidecar) is wrong.
    #[error("recipe source: {0}")]
    Capture(#[from] crate::capture::CaptureError),
    /// The reverse ISP or noise failed.
    #[error("recipe ISP step: {0}")]
    Isp(#[from] crate::isp::IspError),
    /// Recording failed.
    #[error(transparent)]
    Record(#[from] RecordError),
}

impl Recipe {
    /// Read and validate a recipe file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, RecipeError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| RecipeError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let r: Recipe = toml::from_str(&text).map_err(|source| RecipeError::Syntax {
            path: path.to_path_buf(),
            source: Box::new(source),
        })?;
        r.validate()?;
        Ok(r)
    }

    /// Check the values that do not depend on the data.
    pub fn validate(&self) -> Result<(), RecipeError> {
        let bad = |key, value: String, why| Err(RecipeError::Value { key, value, why });
        if self.frames == 0 {
            return bad("frames", "0".into(), "at least 1");
        }
        if !(self.fps > 0.0 && self.fps.is_finite()) {
            return bad("fps", self.fps.to_string(), "a finite number > 0");
        }
        if self.noise_params()?.is_none() && self.noise != "none" {
            return bad("noise", self.noise.clone(), "none, low, medium or high");
        }
        if !["raw", "rgb", "synthetic"].contains(&self.source.kind.as_str()) {
            return bad("source.kind", self.source.kind.clone(), "raw, rgb or synthetic");
        }
        if self.motion.width == 0 || self.motion.height == 0 {
            return bad(
                "motion.width/height",
                format!("{}x{}", self.motion.width, self.motion.height),
                "a non-empty window",
            );
        }
        if self.motion.waypoints.is_empty() {
            return bad("motion.waypoints", "[]".into(), "at least one [x, y]");
        }
        if !self.source.files.is_empty() && (self.source.kind != "rgb" || self.source.file.is_some()) {
            return bad(
                "source.files",
                format!("{} files", self.source.files.len()),
                "kind = \"rgb\" and no source.file",
            );
        }
        if let Some(k) = self.source.scale {
            if !(k > 0.0 && k <= 8.0) || self.source.kind != "rgb" {
                return bad(
                    "source.scale",
                    k.to_string(),
                    "0 < scale <= 8, with kind = \"rgb\"",
                );
            }
        }
        Ok(())
    }

    fn noise_params(&self) -> Result<Option<crate::isp::NoiseParams>, RecipeError> {
        if self.noise == "none" {
            return Ok(None);
        }
        match self.noise.parse::<NoiseLevel>() {
            Ok(l) => Ok(Some(l.params())),
            Err(_) => Err(RecipeError::Value {
                key: "noise",
                value: self.noise.clone(),
                why: "none, low, medium or high",
            }),
        }
    }
}

/// The crop origin of frame `index` of `frames` along `waypoints` (equal time per segment).
pub fn crop_origin(waypoints: &[[usize; 2]], index: u64, frames: u64, align: Align) -> (usize, usize) {
    let (x, y) = match waypoints {
        [] => (0.0, 0.0),
        [p] => (p[0] as f64, p[1] as f64),
        _ => {
            let segs = (waypoints.len() - 1) as f64;
            let t = if frames <= 1 {
                0.0
            } else {
                index as f64 / (frames - 1) as f64
            } * segs;
            let s = (t.floor() as usize).min(waypoints.len() - 2);
            let u = t - s as f64;
            let (a, b) = (waypoints[s], waypoints[s + 1]);
            (
                a[0] as f64 + u * (b[0] as f64 - a[0] as f64),
                a[1] as f64 + u * (b[1] as f64 - a[1] as f64),
            )
        }
    };
    let (x, y) = (x.round() as usize, y.round() as usize);
    match align {
        Align::Any => (x, y),
        Align::Even => (x & !1, y & !1),
    }
}

/// A deterministic synthetic sRGB scene drawn by our own code (no data): sky gradient, ground,
/// coloured boxes and discs, and a block of vertical stripes of rising frequency.
pub(crate) fn synthetic_scene(width: usize, height: usize, seed: u64) -> Image<[u8; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let horizon = height * 3 / 5;
    let mut img = Image::from_fn(width, height, |x, y| {
        if y < horizon {
            let t = y as f32 / horizon.max(1) as f32;
            [
                (90.0 + 80.0 * t) as u8,
                (140.0 + 60.0 * t) as u8,
                (230.0 - 30.0 * t) as u8,
            ]
        } else {
            let t = (y - horizon) as f32 / (height - horizon).max(1) as f32;
            let check = ((x / 16 + y / 16) % 2) as f32 * 12.0;
            [
                (70.0 + 40.0 * t + check) as u8,
                (110.0 + 30.0 * t + check) as u8,
                (50.0 + check) as u8,
            ]
        }
    });
    for _ in 0..12 {
        let (w, h) = (
            rng.random_range(8..width / 4 + 9),
            rng.random_range(8..height / 3 + 9),
        );
        let (x0, y0) = (rng.random_range(0..width), rng.random_range(0..height));
        let c = [rng.random::<u8>(), rng.random::<u8>(), rng.random::<u8>()];
        for y in y0..(y0 + h).min(height) {
            for x in x0..(x0 + w).min(width) {
                img.set(x, y, c);
            }
        }
    }
    for _ in 0..8 {
        let r = rng.random_range(4..(width.min(height) / 6 + 5)) as i64;
        let (cx, cy) = (
            rng.random_range(0..width) as i64,
            rng.random_range(0..height) as i64,
        );
        let c = [rng.random::<u8>(), rng.random::<u8>(), rng.random::<u8>()];
        for y in (cy - r).max(0)..(cy + r).min(height as i64) {
            for x in (cx - r).max(0)..(cx + r).min(width as i64) {
                if (x - cx).pow(2) + (y - cy).pow(2) <= r * r {
                    img.set(x as usize, y as usize, c);
                }
            }
        }
    }
    // Stripes of rising frequency in the lower right quarter.
    for y in height * 3 / 4..height {
        for x in width / 2..width {
            let period = 2 + (width - x) / 16;
            let v = if (x / period).is_multiple_of(2) { 235 } else { 20 };
            img.set(x, y, [v, v, v]);
        }
    }
    img
}

fn profile_for(spec: &SourceSpec) -> Result<CameraProfile, RecipeError> {
    Ok(match &spec.profile {
        Some(stem) => CameraProfile::shipped(stem)?,
        None => CameraProfile::default(),
    })
}

fn reverse_options(spec: &SourceSpec, profile: &CameraProfile) -> Result<ReverseIspOptions, RecipeError> {
    let mut o = ReverseIspOptions::for_profile(profile);
    if let Some(c) = &spec.cfa {
        o.cfa = c.parse::<Cfa>().map_err(|_| RecipeError::Value {
            key: "source.cfa",
            value: c.clone(),
            why: "RGGB, BGGR, GRBG or GBRG",
        })?;
    }
    if let Some(b) = spec.bit_depth {
        o.bit_depth = b;
    }
    Ok(o)
}

/// The still frames of a recipe (files resolved under `data_root`): one, or one per `files`
/// entry; frame `i` of the stream is cut from still `i mod n`.
pub(crate) fn source_frames(recipe: &Recipe, data_root: &Path) -> Result<Vec<RawFrame>, RecipeError> {
    let spec = &recipe.source;
    if spec.files.is_empty() {
        return Ok(vec![source_frame(recipe, data_root)?]);
    }
    let profile = profile_for(spec)?;
    let opts = reverse_options(spec, &profile)?;
    spec.files
        .iter()
        .map(|f| {
            let rgb = scaled(load_rgb8(&data_root.join(f))?, spec.scale);
            Ok(raw_from_srgb(rgb.view(), &profile, &opts)?)
        })
        .collect()
}

/// `rgb` resized by `scale` (bilinear; unchanged when `None` or 1).
fn scaled(rgb: Image<[u8; 3]>, scale: Option<f64>) -> Image<[u8; 3]> {
    let Some(k) = scale.filter(|&k| k != 1.0) else {
        return rgb;
    };
    let (w, h) = rgb.dimensions();
    let buf = image::RgbImage::from_fn(w as u32, h as u32, |x, y| {
        image::Rgb(rgb.get(x as usize, y as usize))
    });
    let (nw, nh) = (
        ((w as f64 * k).round() as u32).max(1),
        ((h as f64 * k).round() as u32).max(1),
    );
    let out = image::imageops::resize(&buf, nw, nh, image::imageops::FilterType::Triangle);
    crate::image_io::rgb8_from_buffer(&out)
}

/// The still frame of a recipe with one source file or scene (files resolved under `data_root`).
pub(crate) fn source_frame(recipe: &Recipe, data_root: &Path) -> Result<RawFrame, RecipeError> {
    let spec = &recipe.source;
    let file = || -> Result<PathBuf, RecipeError> {
        let f = spec.file.as_ref().ok_or(RecipeError::Value {
            key: "source.file",
            value: "(missing)".into(),
            why: "a file under the data root",
        })?;
        Ok(data_root.join(f))
    };
    match spec.kind.as_str() {
        "raw" => {
            let path = file()?;
            match &spec.format {
                Some(s) => Ok(load_headerless(&path, &s.format(&path)?)?),
                None => Ok(load_input(&path, &InputOptions::default())?.frame),
            }
        }
        "rgb" => {
            let rgb = scaled(load_rgb8(&file()?)?, spec.scale);
            let profile = profile_for(spec)?;
            Ok(raw_from_srgb(
                rgb.view(),
                &profile,
                &reverse_options(spec, &profile)?,
            )?)
        }
        _ => {
            let (Some(w), Some(h)) = (spec.width, spec.height) else {
                return Err(RecipeError::Value {
                    key: "source.width/height",
                    value: "(missing)".into(),
                    why: "the synthetic scene size",
                });
            };
            let profile = profile_for(spec)?;
            let rgb = synthetic_scene(w, h, recipe.seed);
            Ok(raw_from_srgb(
                rgb.view(),
                &profile,
                &reverse_options(spec, &profile)?,
            )?)
        }
    }
}

/// Frame `index` of the recipe's stream from its still frame: crop, noise, metadata.
pub(crate) fn recipe_frame(recipe: &Recipe, still: &RawFrame, index: u64) -> Result<RawFrame, RecipeError> {
    let m = &recipe.motion;
    let (x, y) = crop_origin(&m.waypoints, index, recipe.frames, m.align);
    let mut f = still.crop(x, y, m.width, m.height)?;
    if let Some(n) = recipe.noise_params()? {
        f = add_noise_to_raw(&f, n, recipe.seed.wrapping_add(index))?;
    }
    f.meta.sequence = index;
    f.meta.sensor_sequence = Some(index);
    f.meta.timestamp_ns = (index as f64 * 1e9 / recipe.fps).round() as u64;
    f.meta.source = std::sync::Arc::from(format!("recipe:{}", recipe.name).as_str());
    Ok(f)
}

/// Build the recording of `recipe` into `output` (default: the recipe's own output), creating
/// the parent directory. `progress` is called after each frame with (done, total).
pub fn build_recording(
    recipe: &Recipe,
    data_root: &Path,
    output: Option<&Path>,
    mut progress: impl FnMut(u64, u64),
) -> Result<RecordingSummary, RecipeError> {
    recipe.validate()?;
    let stills = source_frames(recipe, data_root)?;
    let out = output.unwrap_or(&recipe.output);
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| RecipeError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    let opts = RecorderOptions {
        camera: recipe.camera.clone(),
        compression_level: recipe.recorder.compression_level,
        flush: FlushPolicy {
            every_frames: Some(recipe.recorder.flush_frames.max(1)),
            every_ns: None,
        },
        rotate: RotatePolicy::from_limits(recipe.recorder.rotate_mb, recipe.recorder.rotate_secs),
        preview: (recipe.recorder.preview_decimation > 0).then_some(PreviewOptions {
            decimation: recipe.recorder.preview_decimation,
        }),
        // Frames only: no result channels that would hold no message.
        results: false,
        ..Default::default()
    };
    let mut rec = McapRecorder::create(out, opts)?;
    for i in 0..recipe.frames {
        let f = recipe_frame(recipe, &stills[(i % stills.len() as u64) as usize], i)?;
        rec.write_frame(&f)?;
        progress(i + 1, recipe.frames);
    }
    Ok(rec.finish()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crop_path_interpolates_segments_and_aligns() {
        let w = [[0, 0], [10, 0], [10, 10]];
        let got: Vec<(usize, usize)> = (0..5).map(|i| crop_origin(&w, i, 5, Align::Any)).collect();
        assert_eq!(got, vec![(0, 0), (5, 0), (10, 0), (10, 5), (10, 10)]);
        let got: Vec<(usize, usize)> = (0..5).map(|i| crop_origin(&w, i, 5, Align::Even)).collect();
        assert_eq!(got, vec![(0, 0), (4, 0), (10, 0), (10, 4), (10, 10)]);
        assert_eq!(crop_origin(&[[3, 7]], 4, 9, Align::Any), (3, 7));
        assert_eq!(crop_origin(&[[3, 7]], 4, 9, Align::Even), (2, 6));
        assert_eq!(crop_origin(&w, 0, 1, Align::Any), (0, 0));
    }

    #[test]
    fn synthetic_scene_is_deterministic_and_seed_dependent() {
        let a = synthetic_scene(64, 48, 1);
        assert_eq!(a, synthetic_scene(64, 48, 1));
        assert_ne!(a, synthetic_scene(64, 48, 2));
    }

    #[test]
    fn recipe_frames_rephase_at_odd_offsets() {
        let toml = r#"
name = "t"
output = "x.mcap"
frames = 3
seed = 5
noise = "low"
[source]
kind = "synthetic"
width = 40
height = 30
cfa = "RGGB"
bit_depth = 12
[motion]
width = 16
height = 12
waypoints = [[0, 0], [3, 1]]
"#;
        let r: Recipe = toml::from_str(toml).unwrap();
        r.validate().unwrap();
        let still = source_frame(&r, Path::new("/nonexistent")).unwrap();
        assert_eq!((still.cfa(), still.bit_depth()), (Cfa::Rggb, 12));
        let f: Vec<RawFrame> = (0..3).map(|i| recipe_frame(&r, &still, i).unwrap()).collect();
        // Origins (0,0), (2,1)→ rounds (1.5→2, 0.5→1), (3,1).
        assert_eq!(f[0].cfa(), Cfa::Rggb);
        assert_eq!(f[1].cfa(), Cfa::Rggb.shifted(2, 1));
        assert_eq!(f[2].cfa(), Cfa::Rggb.shifted(3, 1));
        assert_eq!(f[2].cfa(), Cfa::Bggr);
        assert_eq!(f[1].meta.timestamp_ns, 33_333_333);
        assert_eq!(f[2].meta.sensor_sequence, Some(2));
        // Same index, same bytes.
        assert_eq!(recipe_frame(&r, &still, 1).unwrap(), f[1]);
    }

    #[test]
    fn bad_recipes_name_the_key() {
        let base = r#"
name = "t"
output = "x.mcap"
frames = 3
[source]
kind = "synthetic"
width = 40
height = 30
[motion]
width = 16
height = 12
waypoints = [[0, 0]]
"#;
        let r: Recipe = toml::from_str(&base.replace("frames = 3", "frames = 0")).unwrap();
        assert!(r.validate().unwrap_err().to_string().contains("frames"));
        let r: Recipe =
            toml::from_str(&base.replace("name = \"t\"", "name = \"t\"\nnoise = \"loud\"")).unwrap();
        assert!(r.validate().unwrap_err().to_string().contains("noise = loud"));
        let r: Recipe = toml::from_str(&base.replace("synthetic", "video")).unwrap();
        assert!(r.validate().unwrap_err().to_string().contains("source.kind"));
        assert!(toml::from_str::<Recipe>(&base.replace("frames = 3", "frames = 3\nframez = 1")).is_err());
        // A window that does not fit is an error at the first frame, with the sizes.
        let r: Recipe = toml::from_str(&base.replace("width = 16", "width = 41")).unwrap();
        let still = source_frame(&r, Path::new("/")).unwrap();
        let e = recipe_frame(&r, &still, 0).unwrap_err();
        assert!(e.to_string().contains("41x12"), "{e}");
    }
}
