//! Small PNG plots for the experiments: line plots (with optional bands), overlaid distributions
//! and box plots, drawn with `plotters` and the DejaVu Sans font.
//!
//! The API is data-in, file-out: build a [`LinePlot`] or a list of [`Distribution`]s and call
//! [`line_plot`], [`histogram_plot`] or [`box_plot`]. Log axes are drawn by plotting `log10` of the
//! values and labelling ticks as powers of ten (non-positive values are dropped on a log axis).
//!
//! ```no_run
//! use mosaicd::eval::{line_plot, LinePlot, Scale, Series};
//! let det = Series::new("mosaic", vec![(1e-5, 0.3), (1e-4, 0.12), (1e-3, 0.05)]);
//! let plot = LinePlot {
//!     title: "DET".into(),
//!     x_label: "false positives per window".into(),
//!     y_label: "miss rate".into(),
//!     x_scale: Scale::Log10,
//!     y_scale: Scale::Log10,
//!     ..LinePlot::default()
//! }
//! .with_series(det);
//! line_plot(&plot, std::path::Path::new("out/det.png")).unwrap();
//! ```
//!
//! The font is read once from [`FONT_PATH`] (Debian's `fonts-dejavu-core`); a missing font is a
//! [`PlotError::Font`], never a panic.

use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use thiserror::Error;

/// Where the plot font is read from.
pub(crate) const FONT_PATH: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
/// Font family name the font is registered under.
const FAMILY: &str = "sans-serif";
/// Default image size in pixels.
pub(crate) const DEFAULT_SIZE: (u32, u32) = (800, 560);
/// Series colours, in order (colour-blind-safe Okabe–Ito palette).
const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(240, 228, 66),
];

/// Errors from drawing a plot.
#[derive(Debug, Error)]
pub enum PlotError {
    /// The font could not be read or parsed.
    #[error("cannot load plot font {path}: {reason} (install fonts-dejavu-core)")]
    Font {
        /// Font path.
        path: &'static str,
        /// Why.
        reason: String,
    },
    /// There is nothing to draw (no finite points).
    #[error("plot `{title}` has no finite data to draw")]
    NoData {
        /// Plot title.
        title: String,
    },
    /// The output directory could not be created.
    #[error("cannot create {path}: {source}")]
    Io {
        /// Directory.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Drawing or encoding failed.
    #[error("drawing {path} failed: {reason}")]
    Draw {
        /// Output file.
        path: PathBuf,
        /// Backend message.
        reason: String,
    },
}

type Result<T> = std::result::Result<T, PlotError>;

fn ensure_font() -> Result<()> {
    static FONT: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let bytes = std::fs::read(FONT_PATH).map_err(|e| e.to_string())?;
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font(FAMILY, FontStyle::Normal, bytes)
            .map_err(|_| "not a valid font".to_string())
    })
    .clone()
    .map_err(|reason| PlotError::Font {
        path: FONT_PATH,
        reason,
    })
}

fn prepare(path: &Path) -> Result<()> {
    ensure_font()?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| PlotError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    Ok(())
}

fn draw_err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// Axis scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scale {
    /// Linear axis.
    #[default]
    Linear,
    /// Base-10 logarithmic axis.
    Log10,
}

impl Scale {
    fn apply(self, v: f64) -> Option<f64> {
        match self {
            Scale::Linear => v.is_finite().then_some(v),
            Scale::Log10 => (v.is_finite() && v > 0.0).then(|| v.log10()),
        }
    }
    fn label(self, v: f64) -> String {
        match self {
            Scale::Linear => {
                if v.abs() < 1e-9 {
                    "0".to_string()
                } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
                    format!("{v:.1e}")
                } else {
                    format!("{}", (v * 1000.0).round() / 1000.0)
                }
            }
            Scale::Log10 => {
                let p = 10f64.powf(v);
                if (v - v.round()).abs() < 1e-9 {
                    format!("1e{}", v.round() as i64)
                } else {
                    format!("{p:.1e}")
                }
            }
        }
    }
}

/// Where the legend box goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Legend {
    /// Top right (default).
    #[default]
    UpperRight,
    /// Top left.
    UpperLeft,
    /// Bottom right.
    LowerRight,
    /// Bottom left.
    LowerLeft,
}

impl Legend {
    fn position(self) -> SeriesLabelPosition {
        match self {
            Legend::UpperRight => SeriesLabelPosition::UpperRight,
            Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
            Legend::LowerRight => SeriesLabelPosition::LowerRight,
            Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
        }
    }
}

/// One named curve of a line plot.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points, drawn in the given order.
    pub points: Vec<(f64, f64)>,
    /// Optional shaded band `(low, high)` per point (same length as `points`), e.g. ±1 std.
    pub band: Option<Vec<(f64, f64)>>,
}

impl Series {
    /// A series without a band.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            band: None,
        }
    }
    /// Adds a `(low, high)` band per point.
    pub fn with_band(mut self, band: Vec<(f64, f64)>) -> Self {
        self.band = Some(band);
        self
    }
}

/// A line plot description.
#[derive(Debug, Clone, PartialEq)]
pub struct LinePlot {
    /// Title on top.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// X axis scale.
    pub x_scale: Scale,
    /// Y axis scale.
    pub y_scale: Scale,
    /// Fixed X range (in data units), else fitted to the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed Y range (in data units), else fitted to the data.
    pub y_range: Option<(f64, f64)>,
    /// Draw a marker at every point.
    pub markers: bool,
    /// Image size in pixels.
    pub size: (u32, u32),
    /// Legend position.
    pub legend: Legend,
    /// The curves.
    pub series: Vec<Series>,
}

impl Default for LinePlot {
    fn default() -> Self {
        Self {
            title: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            x_range: None,
            y_range: None,
            markers: false,
            size: DEFAULT_SIZE,
            legend: Legend::UpperRight,
            series: Vec::new(),
        }
    }
}

impl LinePlot {
    /// Appends a series.
    pub fn with_series(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }
}

fn padded(lo: f64, hi: f64) -> (f64, f64) {
    if hi > lo {
        let p = (hi - lo) * 0.04;
        (lo - p, hi + p)
    } else {
        (lo - 0.5, hi + 0.5)
    }
}

fn range_of(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((a, b)) => Some((a.min(v), b.max(v))),
    })
}

/// Draws a line plot to a PNG file (parent directories are created).
pub fn line_plot(plot: &LinePlot, path: &Path) -> Result<()> {
    prepare(path)?;
    let tx = |v: f64| plot.x_scale.apply(v);
    let ty = |v: f64| plot.y_scale.apply(v);
    let mapped: Vec<Vec<(f64, f64)>> = plot
        .series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .filter_map(|&(x, y)| Some((tx(x)?, ty(y)?)))
                .collect()
        })
        .collect();
    let bands: Vec<Vec<(f64, f64, f64)>> = plot
        .series
        .iter()
        .map(|s| match &s.band {
            Some(b) => s
                .points
                .iter()
                .zip(b)
                .filter_map(|(&(x, _), &(lo, hi))| Some((tx(x)?, ty(lo)?, ty(hi)?)))
                .collect(),
            None => Vec::new(),
        })
        .collect();
    let no_data = || PlotError::NoData {
        title: plot.title.clone(),
    };
    let xr = match plot.x_range {
        Some((a, b)) => (tx(a).ok_or_else(no_data)?, tx(b).ok_or_else(no_data)?),
        None => padded_opt(range_of(mapped.iter().flatten().map(|p| p.0))).ok_or_else(no_data)?,
    };
    let yr = match plot.y_range {
        Some((a, b)) => (ty(a).ok_or_else(no_data)?, ty(b).ok_or_else(no_data)?),
        None => padded_opt(range_of(
            mapped
                .iter()
                .flatten()
                .map(|p| p.1)
                .chain(bands.iter().flatten().flat_map(|b| [b.1, b.2])),
        ))
        .ok_or_else(no_data)?,
    };
    let root = BitMapBackend::new(path, plot.size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(&plot.title, (FAMILY, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(|e| draw_err(path, e))?;
    let (xs, ys) = (plot.x_scale, plot.y_scale);
    chart
        .configure_mesh()
        .x_desc(&plot.x_label)
        .y_desc(&plot.y_label)
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .x_label_formatter(&|v| xs.label(*v))
        .y_label_formatter(&|v| ys.label(*v))
        .draw()
        .map_err(|e| draw_err(path, e))?;
    for (i, s) in plot.series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        if !bands[i].is_empty() {
            let mut poly: Vec<(f64, f64)> = bands[i].iter().map(|b| (b.0, b.2)).collect();
            poly.extend(bands[i].iter().rev().map(|b| (b.0, b.1)));
            chart
                .draw_series(std::iter::once(Polygon::new(poly, colour.mix(0.2).filled())))
                .map_err(|e| draw_err(path, e))?;
        }
        chart
            .draw_series(LineSeries::new(mapped[i].iter().copied(), colour.stroke_width(2)))
            .map_err(|e| draw_err(path, e))?
            .label(&s.name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
        if plot.markers {
            chart
                .draw_series(mapped[i].iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(|e| draw_err(path, e))?;
        }
    }
    if plot.series.iter().any(|s| !s.name.is_empty()) {
        chart
            .configure_series_labels()
            .label_font((FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(plot.legend.position())
            .draw()
            .map_err(|e| draw_err(path, e))?;
    }
    root.present().map_err(|e| draw_err(path, e))?;
    Ok(())
}

fn padded_opt(r: Option<(f64, f64)>) -> Option<(f64, f64)> {
    r.map(|(a, b)| padded(a, b))
}

/// A named sample of values for a distribution or box plot.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct Distribution {
    /// Legend / group label.
    pub name: String,
    /// The sample (non-finite values are ignored).
    pub values: Vec<f64>,
}

impl Distribution {
    /// A named sample.
    pub(crate) fn new(name: impl Into<String>, values: Vec<f64>) -> Self {
        Self {
            name: name.into(),
            values,
        }
    }
}

/// Overlaid, normalised histograms (fraction of each sample per bin) drawn as step lines on a
/// common set of `bins` bins spanning all samples. Good for comparing several distributions.
/// The legend goes top left (distributions of scores near 1 crowd the right).
pub(crate) fn histogram_plot(
    title: &str,
    x_label: &str,
    dists: &[Distribution],
    bins: usize,
    path: &Path,
) -> Result<()> {
    let no_data = || PlotError::NoData {
        title: title.to_string(),
    };
    let bins = bins.max(1);
    let (lo, hi) = range_of(
        dists
            .iter()
            .flat_map(|d| d.values.iter().copied().filter(|v| v.is_finite())),
    )
    .ok_or_else(no_data)?;
    let (lo, hi) = if hi > lo { (lo, hi) } else { (lo - 0.5, hi + 0.5) };
    let width = (hi - lo) / bins as f64;
    let mut plot = LinePlot {
        title: title.to_string(),
        x_label: x_label.to_string(),
        y_label: "fraction".to_string(),
        legend: Legend::UpperLeft,
        ..LinePlot::default()
    };
    for d in dists {
        let finite: Vec<f64> = d.values.iter().copied().filter(|v| v.is_finite()).collect();
        let mut counts = vec![0usize; bins];
        for v in &finite {
            let b = (((v - lo) / width) as usize).min(bins - 1);
            counts[b] += 1;
        }
        let n = finite.len().max(1) as f64;
        let mut pts = Vec::with_capacity(2 * bins + 2);
        pts.push((lo, 0.0));
        for (b, &c) in counts.iter().enumerate() {
            let f = c as f64 / n;
            pts.push((lo + b as f64 * width, f));
            pts.push((lo + (b + 1) as f64 * width, f));
        }
        pts.push((hi, 0.0));
        plot.series.push(Series::new(d.name.clone(), pts));
    }
    line_plot(&plot, path)
}

/// Summary statistics of a sample (what a box plot draws).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct BoxStats {
    /// Minimum.
    pub min: f64,
    /// First quartile (linear interpolation, numpy's default).
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// Third quartile.
    pub q3: f64,
    /// Maximum.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

/// Quartiles, extremes and mean of the finite values; `None` for an empty sample.
pub(crate) fn box_stats(values: &[f64]) -> Option<BoxStats> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| {
        let pos = p * (v.len() - 1) as f64;
        let (i, f) = (pos.floor() as usize, pos.fract());
        if i + 1 < v.len() {
            v[i] * (1.0 - f) + v[i + 1] * f
        } else {
            v[i]
        }
    };
    Some(BoxStats {
        min: v[0],
        q1: q(0.25),
        median: q(0.5),
        q3: q(0.75),
        max: v[v.len() - 1],
        mean: v.iter().sum::<f64>() / v.len() as f64,
    })
}

/// Box plot: one box (quartiles, median line, min–max whiskers, mean dot) per distribution.
pub(crate) fn box_plot(title: &str, y_label: &str, dists: &[Distribution], path: &Path) -> Result<()> {
    prepare(path)?;
    let no_data = || PlotError::NoData {
        title: title.to_string(),
    };
    let stats: Vec<Option<BoxStats>> = dists.iter().map(|d| box_stats(&d.values)).collect();
    let (lo, hi) = range_of(stats.iter().flatten().flat_map(|s| [s.min, s.max])).ok_or_else(no_data)?;
    let (lo, hi) = padded(lo, hi);
    let n = dists.len() as f64;
    let root = BitMapBackend::new(path, DEFAULT_SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FAMILY, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5..n - 0.5, lo..hi)
        .map_err(|e| draw_err(path, e))?;
    let names: Vec<String> = dists.iter().map(|d| d.name.clone()).collect();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .y_desc(y_label)
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .x_labels(dists.len().max(1))
        .x_label_formatter(&|v| {
            let i = v.round();
            if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < names.len() {
                names[i as usize].clone()
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| Scale::Linear.label(*v))
        .draw()
        .map_err(|e| draw_err(path, e))?;
    for (i, s) in stats.iter().enumerate() {
        let Some(s) = s else { continue };
        let colour = PALETTE[i % PALETTE.len()];
        let x = i as f64;
        let hw = 0.3;
        let elems: Vec<DynElement<'static, BitMapBackend, (f64, f64)>> = vec![
            Rectangle::new([(x - hw, s.q1), (x + hw, s.q3)], colour.mix(0.3).filled()).into_dyn(),
            Rectangle::new([(x - hw, s.q1), (x + hw, s.q3)], colour.stroke_width(2)).into_dyn(),
            PathElement::new(
                vec![(x - hw, s.median), (x + hw, s.median)],
                BLACK.stroke_width(2),
            )
            .into_dyn(),
            PathElement::new(vec![(x, s.q3), (x, s.max)], colour.stroke_width(1)).into_dyn(),
            PathElement::new(vec![(x, s.q1), (x, s.min)], colour.stroke_width(1)).into_dyn(),
            PathElement::new(
                vec![(x - hw / 2.0, s.max), (x + hw / 2.0, s.max)],
                colour.stroke_width(1),
            )
            .into_dyn(),
            PathElement::new(
                vec![(x - hw / 2.0, s.min), (x + hw / 2.0, s.min)],
                colour.stroke_width(1),
            )
            .into_dyn(),
            Circle::new((x, s.mean), 4, BLACK.filled()).into_dyn(),
        ];
        chart.draw_series(elems).map_err(|e| draw_err(path, e))?;
    }
    root.present().map_err(|e| draw_err(path, e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png_ok(p: &Path) {
        let bytes = std::fs::read(p).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{} is not a PNG", p.display());
        let img = image::open(p).unwrap().to_rgb8();
        // Something other than white was drawn.
        assert!(img.pixels().any(|px| px.0 != [255, 255, 255]));
    }

    #[test]
    fn draws_all_kinds() {
        let dir = tempfile::tempdir().unwrap();
        let lp = LinePlot {
            title: "DET".into(),
            x_label: "FPPW".into(),
            y_label: "miss rate".into(),
            x_scale: Scale::Log10,
            y_scale: Scale::Log10,
            markers: true,
            ..LinePlot::default()
        }
        .with_series(Series::new(
            "a",
            vec![(1e-5, 0.5), (1e-4, 0.2), (1e-3, 0.05), (0.0, 0.01)],
        ))
        .with_series(
            Series::new("b", vec![(1e-5, 0.6), (1e-4, 0.3), (1e-3, 0.1)]).with_band(vec![
                (0.5, 0.7),
                (0.2, 0.4),
                (0.05, 0.2),
            ]),
        );
        let p = dir.path().join("sub/line.png");
        line_plot(&lp, &p).unwrap();
        png_ok(&p);
        let d = vec![
            Distribution::new("grey", (0..100).map(|i| (i as f64 * 0.37).sin()).collect()),
            Distribution::new("R", (0..80).map(|i| (i as f64 * 0.11).cos() * 0.5).collect()),
        ];
        let h = dir.path().join("hist.png");
        histogram_plot("dist", "GMSD", &d, 20, &h).unwrap();
        png_ok(&h);
        let b = dir.path().join("box.png");
        box_plot("box", "GMSD", &d, &b).unwrap();
        png_ok(&b);
    }

    #[test]
    fn empty_data_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let lp = LinePlot::default().with_series(Series::new("x", vec![(f64::NAN, 1.0)]));
        assert!(matches!(
            line_plot(&lp, &dir.path().join("x.png")),
            Err(PlotError::NoData { .. })
        ));
        assert!(matches!(
            box_plot(
                "t",
                "y",
                &[Distribution::new("e", vec![])],
                &dir.path().join("b.png")
            ),
            Err(PlotError::NoData { .. })
        ));
    }

    #[test]
    fn box_stats_hand_computed() {
        let s = box_stats(&[4.0, 1.0, 3.0, 2.0, f64::NAN]).unwrap();
        assert_eq!(
            (s.min, s.q1, s.median, s.q3, s.max, s.mean),
            (1.0, 1.75, 2.5, 3.25, 4.0, 2.5)
        );
        assert!(box_stats(&[]).is_none());
    }
}
