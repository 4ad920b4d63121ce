//! Shared pieces of the experiments: errors, inputs (Kodak, raw frames), the small image helpers
//! every table needs, result tables and progress.
//!
//! The image helpers are thin wrappers over the project's modules (`raw::sample`, `isp::grey`,
//! `features::gradient`, `raw::load`) so that every experiment uses the same conventions.

use crate::features::superpixel::SuperPixelError;
use crate::image::{Image, ImageView};
use crate::metrics::MetricsError;
use crate::raw::Cfa;
use std::path::{Path, PathBuf};
use thiserror::Error;

use super::plot::PlotError;

/// Errors from running an experiment.
#[derive(Debug, Error)]
pub enum EvalError {
    /// Shared data is missing.
    #[error(transparent)]
    Data(#[from] crate::data::DataMissing),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// An image file could not be decoded.
    #[error("cannot decode {path}: {reason}")]
    Decode {
        /// File.
        path: PathBuf,
        /// Decoder message.
        reason: String,
    },
    /// A raw file could not be loaded.
    #[error(transparent)]
    Raw(#[from] crate::raw::RawError),
    /// A raw scene of the shared data could not be found or loaded.
    #[error(transparent)]
    RawScene(#[from] crate::data::RawSceneError),
    /// A gradient computation failed.
    #[error(transparent)]
    Gradient(#[from] crate::features::gradient::GradientError),
    /// An ISP step (demosaicing, noise, forward ISP) failed.
    #[error(transparent)]
    Isp(#[from] crate::isp::IspError),
    /// A metric failed.
    #[error(transparent)]
    Metrics(#[from] MetricsError),
    /// A super-pixel operation failed.
    #[error(transparent)]
    SuperPixel(#[from] SuperPixelError),
    /// A resize failed.
    #[error(transparent)]
    Resize(#[from] crate::resize::ResizeError),
    /// A plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// `--limit 0` or no input selected.
    #[error("no input images selected (limit {limit})")]
    NoInputs {
        /// The limit given.
        limit: usize,
    },
}

/// Result alias for the experiments.
pub type Result<T> = std::result::Result<T, EvalError>;

/// Options shared by every experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalOptions {
    /// Use at most this many Kodak images; `None` = all 24.
    pub limit: Option<usize>,
    /// Use at most this many real raw frames; `None` = all.
    pub raw_limit: Option<usize>,
    /// Directory for plots and the markdown report.
    pub out: PathBuf,
    /// Print progress to stderr.
    pub progress: bool,
}

/// Number of Kodak images.
pub(crate) const KODAK_COUNT: usize = 24;

/// `kodim01` … `kodim24`, the first `limit`.
pub(crate) fn kodak_names(limit: Option<usize>) -> Result<Vec<String>> {
    let n = limit.unwrap_or(KODAK_COUNT).min(KODAK_COUNT);
    if n == 0 {
        return Err(EvalError::NoInputs { limit: 0 });
    }
    Ok((1..=n).map(|i| format!("kodim{i:02}")).collect())
}

/// A Kodak image as RGB on [0, 1].
pub(crate) fn load_kodak(name: &str) -> Result<Image<[f32; 3]>> {
    let path = crate::data::data_path(&format!("kodak/{name}.png"))?;
    load_rgb(&path)
}

/// Any 8-bit RGB image file as RGB on [0, 1].
pub(crate) fn load_rgb(path: &Path) -> Result<Image<[f32; 3]>> {
    let rgb = crate::image_io::load_rgb8(path).map_err(|e| EvalError::Decode {
        path: e.path,
        reason: e.source.to_string(),
    })?;
    Ok(rgb.map(|p| p.map(|c| c as f32 / 255.0)))
}

pub(crate) use crate::data::{load_raw_frame, raw_inputs, raw_profile, RawInput};

/// Samples an RGB image through a CFA (both greens take G): `raw::sample::mosaic_from_rgb`.
pub(crate) fn mosaic_from_rgb(rgb: ImageView<'_, [f32; 3]>, cfa: Cfa) -> Image<f32> {
    crate::raw::sample::mosaic_from_rgb(&rgb, cfa)
}

/// BT.601 luma `0.299 R + 0.587 G + 0.114 B` (OpenCV's `COLOR_RGB2GRAY`, MATLAB's `rgb2gray`):
/// `isp::grey::grey_from_rgb_f32`.
pub(crate) fn grey_from_rgb(rgb: ImageView<'_, [f32; 3]>) -> Image<f32> {
    crate::isp::grey::grey_from_rgb_f32(&rgb)
}

/// One channel of an RGB image.
pub(crate) fn channel(rgb: ImageView<'_, [f32; 3]>, c: usize) -> Image<f32> {
    Image::from_fn(rgb.width(), rgb.height(), |x, y| rgb.get(x, y)[c])
}

/// Scale of the gradient magnitude maps the tables compare: `½ √(gx² + gy²)` with the `[-1, 0, 1]`
/// operator, i.e. the derivative per pixel, so a [0, 1] image gives magnitudes in [0, √2/2] and the
/// paper's `c = 0.0026` (for magnitudes on [0, 1]) applies.
pub(crate) const MAGNITUDE_SCALE: f32 = 0.5;

/// Central-difference gradient magnitude (`[-1, 0, 1]`, reflect-101 borders as OpenCV, from
/// `features::gradient::gradients_from_image`), times [`MAGNITUDE_SCALE`]. On a mosaic the taps are
/// two pixels apart and always of one colour.
pub(crate) fn gradient_magnitude(img: ImageView<'_, f32>) -> Result<Image<f32>> {
    use crate::features::gradient::{gradients_from_image, GradientSpec};
    let g = gradients_from_image(&img, &GradientSpec::default())?;
    Ok(g.magnitude().map(|v| v * MAGNITUDE_SCALE))
}

/// Per-pixel maximum over the three channels' gradient magnitudes (Dalal & Triggs' colour rule).
pub(crate) fn colour_max_gradient_magnitude(rgb: ImageView<'_, [f32; 3]>) -> Result<Image<f32>> {
    let m: Vec<Image<f32>> = (0..3)
        .map(|c| gradient_magnitude(channel(rgb, c).view()))
        .collect::<Result<_>>()?;
    Ok(Image::from_fn(rgb.width(), rgb.height(), |x, y| {
        m[0].get(x, y).max(m[1].get(x, y)).max(m[2].get(x, y))
    }))
}

/// Crops an image to even width and height (mosaic operations need whole 2x2 tiles).
pub(crate) fn even_crop<P: Copy>(img: &Image<P>) -> Image<P> {
    let (w, h) = (img.width() & !1, img.height() & !1);
    img.view().crop(0, 0, w, h).expect("inside").to_image()
}

/// Mean of the finite values and how many were not finite (PSNR of identical inputs is +∞).
pub(crate) fn finite_mean(v: &[f64]) -> (f64, usize) {
    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let mean = if f.is_empty() {
        f64::NAN
    } else {
        f.iter().sum::<f64>() / f.len() as f64
    };
    (mean, v.len() - f.len())
}

/// A result table: printed as aligned text and written as markdown.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Caption.
    pub title: String,
    /// Column headers.
    pub headers: Vec<String>,
    /// Rows of cells.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// An empty table with headers.
    pub fn new(title: impl Into<String>, headers: &[&str]) -> Self {
        Self {
            title: title.into(),
            headers: headers.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }
    /// Appends a row.
    pub fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }
    /// Aligned plain text.
    pub fn to_text(&self) -> String {
        let n = self.headers.len();
        let mut wid: Vec<usize> = self.headers.iter().map(|h| h.chars().count()).collect();
        for r in &self.rows {
            for (i, c) in r.iter().enumerate().take(n) {
                wid[i] = wid[i].max(c.chars().count());
            }
        }
        let line = |cells: &[String]| {
            cells
                .iter()
                .enumerate()
                .map(|(i, c)| format!("{c:<w$}", w = wid.get(i).copied().unwrap_or(0)))
                .collect::<Vec<_>>()
                .join("  ")
        };
        let mut s = format!("{}\n{}\n", self.title, line(&self.headers));
        s.push_str(&wid.iter().map(|w| "-".repeat(*w)).collect::<Vec<_>>().join("  "));
        s.push('\n');
        for r in &self.rows {
            s.push_str(&line(r));
            s.push('\n');
        }
        s
    }
    /// GitHub markdown.
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "**{}**\n\n| {} |\n|{}\n",
            self.title,
            self.headers.join(" | "),
            "---|".repeat(self.headers.len())
        );
        for r in &self.rows {
            s.push_str(&format!("| {} |\n", r.join(" | ")));
        }
        s
    }
}

/// What an experiment produced.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Report {
    /// Experiment name (the subcommand).
    pub name: String,
    /// Heading for the markdown section.
    pub heading: String,
    /// Tables.
    pub tables: Vec<Table>,
    /// PNG plots written.
    pub plots: Vec<PathBuf>,
    /// Notes: what was measured, how we differ from the paper, and why.
    pub notes: Vec<String>,
}

impl Report {
    /// Plain-text rendering for the terminal.
    pub fn to_text(&self) -> String {
        let mut s = format!("== {} ==\n", self.heading);
        for t in &self.tables {
            s.push_str(&t.to_text());
            s.push('\n');
        }
        for p in &self.plots {
            s.push_str(&format!("plot: {}\n", p.display()));
        }
        for n in &self.notes {
            s.push_str(&format!("note: {n}\n"));
        }
        s
    }
    /// Markdown section (plots linked relative to `base` when possible).
    pub fn to_markdown(&self, base: Option<&Path>) -> String {
        let mut s = format!("## {}\n\n", self.heading);
        for t in &self.tables {
            s.push_str(&t.to_markdown());
            s.push('\n');
        }
        for p in &self.plots {
            let shown = base.and_then(|b| p.strip_prefix(b).ok()).unwrap_or(p);
            s.push_str(&format!("Plot: `{}`\n\n", shown.display()));
        }
        for n in &self.notes {
            s.push_str(&format!("- {n}\n"));
        }
        s.push('\n');
        s
    }
    /// Writes `OUT/<name>.md`.
    pub fn write(&self, out: &Path) -> Result<PathBuf> {
        std::fs::create_dir_all(out).map_err(|source| EvalError::Io {
            path: out.to_path_buf(),
            source,
        })?;
        let p = out.join(format!("{}.md", self.name));
        std::fs::write(&p, self.to_markdown(Some(out))).map_err(|source| EvalError::Io {
            path: p.clone(),
            source,
        })?;
        Ok(p)
    }
}

/// Progress over the images of an experiment: a bar on stderr ([`crate::progress::Progress`])
/// when enabled and stderr is a terminal, nothing otherwise (no `\r` lines in CI logs).
#[derive(Debug)]
pub(crate) struct Progress {
    shown: crate::progress::Progress,
}

impl Progress {
    /// A counter for `total` steps.
    pub(crate) fn new(label: &str, total: usize, enabled: bool) -> Self {
        let shown = if enabled {
            crate::progress::Progress::new(label, Some(total as u64))
        } else {
            crate::progress::Progress::with_display(false, label, None)
        };
        Self { shown }
    }
    /// Reports step `i` (0-based) on `what`.
    pub(crate) fn step(&self, i: usize, what: &str) {
        self.shown.set(i as u64, what);
    }
    /// Ends the display.
    pub(crate) fn done(&self) {
        self.shown.finish();
    }
}

/// Formats a number with `d` decimals; `inf`/`nan` spelled out.
pub(crate) fn fmt(v: f64, d: usize) -> String {
    if v.is_finite() {
        format!("{v:.d$}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_magnitude_hand_computed() {
        // Horizontal ramp of step 0.1: gx = 0.2 inside, ½ · 0.2 = 0.1; reflect-101 gives 0 at the border.
        let r = Image::from_fn(5, 3, |x, _| x as f32 * 0.1);
        let m = gradient_magnitude(r.view()).unwrap();
        assert!((m.get(2, 1) - 0.1).abs() < 1e-6);
        assert_eq!(m.get(0, 1), 0.0);
        assert_eq!(m.get(4, 1), 0.0);
    }

    #[test]
    fn flat_mosaic_has_zero_gradient() {
        let rgb = Image::filled(6, 4, [0.2f32, 0.5, 0.7]);
        let m = mosaic_from_rgb(rgb.view(), Cfa::Rggb);
        assert_eq!(m.get(0, 0), 0.2);
        assert_eq!(m.get(1, 0), 0.5);
        assert_eq!(m.get(1, 1), 0.7);
        assert!(gradient_magnitude(m.view())
            .unwrap()
            .as_slice()
            .iter()
            .all(|&v| v == 0.0));
    }

    #[test]
    fn table_renders() {
        let mut t = Table::new("T", &["a", "bb"]);
        t.row(vec!["1".into(), "2".into()]);
        assert!(t.to_text().contains("a  bb"));
        assert!(t.to_markdown().contains("| a | bb |\n|---|---|\n| 1 | 2 |"));
        assert_eq!(finite_mean(&[1.0, f64::INFINITY, 3.0]), (2.0, 1));
    }
}
