//! Full-image detection evaluation: ground-truth boxes (USC Pedestrian Sets A/B/C or any directory
//! with a box CSV), the detector run over every image, greedy PASCAL matching at IoU ≥ 0.5, average
//! precision, recall and precision/recall curves; plus the DET and PR plots of `mosaicd eval
//! detection`.
//!
//! ```
//! use mosaicd::eval::{parse_box_csv, Shrink};
//! use std::path::Path;
//! let csv = "image,x,y,w,h\na.png,10,20,30,60\na.png,50,20,30,60\n";
//! let recs = parse_box_csv(csv, Path::new("boxes.csv")).unwrap();
//! assert_eq!(recs.len(), 2);
//! assert_eq!(recs[1].rect.x, 50.0);
//! // A bad row names its line.
//! let err = parse_box_csv("image,x,y,w,h\na.png,1,2,three,4\n", Path::new("b.csv")).unwrap_err();
//! assert!(err.to_string().contains("b.csv:2"));
//! // The shrunk-box convention: a 64x128 window → the 38.4x102.4 person inside it.
//! let s = Shrink::DOC;
//! assert_eq!((s.x, s.y, s.width, s.height), (0.2, 0.1, 0.6, 0.8));
//! ```
//!
//! # Ground truth
//! - **Box CSV** ([`parse_box_csv`]): a header naming at least `image`, `x`, `y` and `w`/`width`,
//!   `h`/`height` (top-left corner and size in pixels), optionally `set` (a sub-directory holding the
//!   image); other columns are ignored. `usc_boxes_derived.csv` is of this form
//!   (`set,image,img_w,img_h,x,y,w,h`). Images are resolved as `DIR/set/image` or `DIR/image`.
//! - **USC Sets A and B** ([`parse_usc_xml`]): one `NAME.gt.xml` per image with `<Rect x y width
//!   height>` elements.
//! - **USC Set C** ([`parse_human_gt`]): `GT/human_GT.txt`, one `image x y w h` per line.
//!
//! [`load_usc`] reads A and B from their XML files and C from `human_GT.txt` (a test checks the
//! three sources agree with `usc_boxes_derived.csv` box for box).
//!
//! # Matching and AP
//! `metrics::detection::match_detections`: detections of all images sorted by score, each
//! matched to the unmatched ground-truth box of its image with the highest IoU ≥ 0.5, otherwise a
//! false positive (duplicates included); AP is the VOC 2010+ all-points area under the monotone
//! precision envelope; recall is the fraction of boxes matched at the loosest threshold.
//!
//! ## Shrunk boxes
//! USC boxes are drawn tight around the person while a detector window has margins (a 64x128
//! window holds a ~96 px tall person), so a correct detection rarely reaches IoU 0.5 against the
//! raw box. [`Shrink::DOC`] maps every detection `(x, y, w, h)` to `(x + 0.2w, y + 0.1h, 0.6w, 0.8h)`
//! before matching, the same map for every detector compared; `mosaicd eval detection` reports AP
//! with raw and with shrunk detections. This is our convention, not USC's or PASCAL's.
//!
//! # References
//! - B. Wu, R. Nevatia, "Detection of Multiple, Partially Occluded Humans in a Single Image by
//!   Bayesian Combination of Edgelet Part Detectors", ICCV 2005 (USC Pedestrian Sets).
//! - M. Everingham et al., "The PASCAL Visual Object Classes (VOC) Challenge", IJCV 2010.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::detect::people::{PeopleDetector, PeopleInput};
use crate::detect::train::{DomainImage, InputPipeline};
use crate::detect::{Detection, Domain};
use crate::eval::plot::{line_plot, Legend, LinePlot, Scale, Series};
use crate::image::Image;
use crate::metrics::detection::{
    average_precision, log_average_miss_rate, match_detections, mr_fppi_curve, ApMethod, DetPoint,
    ImageDetections, MatchedDetections, Rect,
};
/// Re-exported from [`crate::metrics`], where it lives.
pub(crate) use crate::metrics::interval::Interval;
use crate::raw::levels::Gains;
use crate::raw::Cfa;

/// USC data directory relative to the data root.
pub(crate) const USC_DIR: &str = "pedestrian/usc";
/// The USC sets read by [`load_usc`], in order, and whether their boxes are in per-image XML files
/// (`true`) or in `GT/human_GT.txt` (`false`).
pub(crate) const USC_SETS: [(&str, bool); 3] = [
    ("USCPedestrianSetA", true),
    ("USCPedestrianSetB", true),
    ("USCPedestrianSetC", false),
];
/// PR curve points kept for plotting.
const PR_PLOT_POINTS: usize = 400;

/// Errors of the detection evaluation.
#[derive(Debug, thiserror::Error)]
pub enum DetEvalError {
    /// The shared data is missing.
    #[error(transparent)]
    Data(#[from] crate::data::DataMissing),
    /// A file or directory could not be read.
    #[error("{path}: {source}")]
    Io {
        /// File or directory.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// A ground-truth or detection file has a bad line.
    #[error("{path}:{line}: {reason}")]
    Parse {
        /// File.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// An image named by the ground truth does not exist.
    #[error("{key}: image not found (looked for {tried})")]
    MissingImage {
        /// Image key (`set/image`).
        key: String,
        /// Paths tried.
        tried: String,
    },
    /// An image could not be decoded.
    #[error("cannot decode {path}: {reason}")]
    Decode {
        /// File.
        path: PathBuf,
        /// Decoder message.
        reason: String,
    },
    /// No images selected.
    #[error("no images with ground truth selected ({what})")]
    NoImages {
        /// Which selection.
        what: String,
    },
    /// The detector failed.
    #[error(transparent)]
    Detect(#[from] crate::detect::DetectError),
    /// A HOG or ACF model did not load, or its detector failed.
    #[error(transparent)]
    People(#[from] crate::detect::people::PeopleError),
    /// A raw frame could not be brought into the model's tone (e.g. bad gains).
    #[error(transparent)]
    Raw(crate::raw::RawError),
    /// A buffer did not match the frame.
    #[error(transparent)]
    Image(crate::image::ImageError),
    /// Bringing an image into the model's domain failed.
    #[error(transparent)]
    Input(#[from] crate::detect::train::TrainError),
    /// A model file does not load.
    #[error(transparent)]
    Model(#[from] crate::detect::model::ModelError),
    /// A metric failed.
    #[error(transparent)]
    Metrics(#[from] crate::metrics::MetricsError),
    /// A plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] crate::eval::plot::PlotError),
}

/// Result alias of this module.
pub(crate) type Result<T> = std::result::Result<T, DetEvalError>;

/// One ground-truth box as read from a file.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxRecord {
    /// Sub-directory of the image (`set` column), if any.
    pub set: Option<String>,
    /// Image file name.
    pub image: String,
    /// The box.
    pub rect: Rect,
}

impl BoxRecord {
    /// `set/image`, or `image` without a set: the key images and detections are matched by.
    pub fn key(&self) -> String {
        image_key(self.set.as_deref(), &self.image)
    }
}

fn image_key(set: Option<&str>, image: &str) -> String {
    match set {
        Some(s) if !s.is_empty() => format!("{s}/{image}"),
        _ => image.to_string(),
    }
}

fn parse_err(path: &Path, line: usize, reason: impl Into<String>) -> DetEvalError {
    DetEvalError::Parse {
        path: path.to_path_buf(),
        line,
        reason: reason.into(),
    }
}

fn number(path: &Path, line: usize, name: &str, v: &str) -> Result<f32> {
    let x: f32 = v
        .trim()
        .parse()
        .map_err(|_| parse_err(path, line, format!("{name} = {v:?} is not a number")))?;
    if !x.is_finite() {
        return Err(parse_err(path, line, format!("{name} = {v:?} is not finite")));
    }
    Ok(x)
}

fn rect_checked(path: &Path, line: usize, x: f32, y: f32, w: f32, h: f32) -> Result<Rect> {
    if w <= 0.0 || h <= 0.0 {
        return Err(parse_err(
            path,
            line,
            format!("box size {w}x{h} must be positive"),
        ));
    }
    Ok(Rect {
        x,
        y,
        width: w,
        height: h,
    })
}

/// Column positions of a CSV header, by any of the accepted names.
fn column(header: &[&str], names: &[&str]) -> Option<usize> {
    header
        .iter()
        .position(|h| names.iter().any(|n| h.trim().eq_ignore_ascii_case(n)))
}

/// A CSV text with a header line, split into fields; blank lines are skipped and every row must
/// have at least the header's field count. Errors name the file and the 1-based line.
struct Csv<'a> {
    origin: &'a Path,
    /// Line of the header (1-based).
    header_line: usize,
    header: Vec<&'a str>,
    /// What the header must name, for error messages (`image,x,y,w,h`).
    need: &'static str,
    /// (line, fields) of every data row.
    rows: Vec<(usize, Vec<&'a str>)>,
}

impl<'a> Csv<'a> {
    fn parse(text: &'a str, origin: &'a Path, need: &'static str) -> Result<Self> {
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
        let Some((hl, header)) = lines.next() else {
            return Err(parse_err(
                origin,
                1,
                format!("empty file: expected a header with {need}"),
            ));
        };
        let header: Vec<&str> = header.split(',').collect();
        let mut rows = Vec::new();
        for (i, l) in lines {
            let f: Vec<&str> = l.split(',').collect();
            if f.len() < header.len() {
                return Err(parse_err(
                    origin,
                    i + 1,
                    format!("{} fields, the header has {}", f.len(), header.len()),
                ));
            }
            rows.push((i + 1, f));
        }
        Ok(Self {
            origin,
            header_line: hl + 1,
            header,
            need,
            rows,
        })
    }

    /// The column called any of `names` (the first is the one errors name).
    fn column(&self, names: &[&str]) -> Result<usize> {
        column(&self.header, names).ok_or_else(|| {
            parse_err(
                self.origin,
                self.header_line,
                format!("header lacks a `{}` column (need {})", names[0], self.need),
            )
        })
    }
}

/// Parse a box CSV (see the module docs). `origin` names the file in errors.
pub fn parse_box_csv(text: &str, origin: &Path) -> Result<Vec<BoxRecord>> {
    let csv = Csv::parse(text, origin, "image,x,y,w,h; optional set")?;
    let (ci, cx, cy, cw, ch) = (
        csv.column(&["image", "file", "filename"])?,
        csv.column(&["x"])?,
        csv.column(&["y"])?,
        csv.column(&["w", "width"])?,
        csv.column(&["h", "height"])?,
    );
    let cs = column(&csv.header, &["set"]);
    let mut out = Vec::new();
    for (n, f) in csv.rows {
        let image = f[ci].trim();
        if image.is_empty() {
            return Err(parse_err(origin, n, "empty image name"));
        }
        let rect = rect_checked(
            origin,
            n,
            number(origin, n, "x", f[cx])?,
            number(origin, n, "y", f[cy])?,
            number(origin, n, "w", f[cw])?,
            number(origin, n, "h", f[ch])?,
        )?;
        out.push(BoxRecord {
            set: cs.map(|c| f[c].trim().to_string()).filter(|s| !s.is_empty()),
            image: image.to_string(),
            rect,
        });
    }
    Ok(out)
}

/// The value of attribute `name` inside one XML tag's text.
fn xml_attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let mut rest = tag;
    while let Some(p) = rest.find(name) {
        let before_ok = p == 0 || rest.as_bytes()[p - 1].is_ascii_whitespace();
        let after = rest[p + name.len()..].trim_start();
        if before_ok {
            if let Some(v) = after.strip_prefix('=') {
                let v = v.trim_start();
                let q = v.chars().next()?;
                if q == '"' || q == '\'' {
                    let end = v[1..].find(q)?;
                    return Some(&v[1..1 + end]);
                }
            }
        }
        rest = &rest[p + name.len()..];
    }
    None
}

/// Parse a USC `NAME.gt.xml` (Sets A and B): every `<Rect x= y= width= height=/>` element.
pub(crate) fn parse_usc_xml(text: &str, origin: &Path) -> Result<Vec<Rect>> {
    let mut out = Vec::new();
    if !text.contains("<ObjectList") {
        return Err(parse_err(
            origin,
            1,
            "not a USC ground-truth file (no <ObjectList>)",
        ));
    }
    let mut pos = 0;
    while let Some(off) = text[pos..].find("<Rect") {
        let start = pos + off;
        let line = text[..start].matches('\n').count() + 1;
        let end = text[start..]
            .find('>')
            .map(|e| start + e)
            .ok_or_else(|| parse_err(origin, line, "unterminated <Rect> tag"))?;
        let tag = &text[start + "<Rect".len()..end];
        let get = |n: &str| -> Result<f32> {
            let v = xml_attr(tag, n)
                .ok_or_else(|| parse_err(origin, line, format!("<Rect> lacks the `{n}` attribute")))?;
            number(origin, line, n, v)
        };
        out.push(rect_checked(
            origin,
            line,
            get("x")?,
            get("y")?,
            get("width")?,
            get("height")?,
        )?);
        pos = end;
    }
    Ok(out)
}

/// Parse USC Set C's `GT/human_GT.txt`: `image x y w h` per line (blank lines skipped).
pub(crate) fn parse_human_gt(text: &str, origin: &Path) -> Result<Vec<BoxRecord>> {
    let mut out = Vec::new();
    for (i, l) in text.lines().enumerate() {
        let n = i + 1;
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.is_empty() {
            continue;
        }
        if f.len() != 5 {
            return Err(parse_err(
                origin,
                n,
                format!("{} fields, expected `image x y w h`", f.len()),
            ));
        }
        let rect = rect_checked(
            origin,
            n,
            number(origin, n, "x", f[1])?,
            number(origin, n, "y", f[2])?,
            number(origin, n, "w", f[3])?,
            number(origin, n, "h", f[4])?,
        )?;
        out.push(BoxRecord {
            set: None,
            image: f[0].to_string(),
            rect,
        });
    }
    Ok(out)
}

/// An image with its ground-truth boxes.
#[derive(Debug, Clone, PartialEq)]
pub struct GtImage {
    /// `set/image` (or `image`): the key detections are matched by.
    pub key: String,
    /// Image file.
    pub path: PathBuf,
    /// Ground-truth boxes.
    pub boxes: Vec<Rect>,
}

fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|source| DetEvalError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Group records by image (sorted by key) and resolve each image under `dir` (`dir/set/image`, else
/// `dir/image`); a missing image file is an error naming it.
pub(crate) fn images_from_records(dir: &Path, records: &[BoxRecord]) -> Result<Vec<GtImage>> {
    let mut by_key: BTreeMap<String, (Option<&str>, &str, Vec<Rect>)> = BTreeMap::new();
    for r in records {
        by_key
            .entry(r.key())
            .or_insert_with(|| (r.set.as_deref(), r.image.as_str(), Vec::new()))
            .2
            .push(r.rect);
    }
    by_key
        .into_iter()
        .map(|(key, (set, image, boxes))| {
            let mut tried = Vec::new();
            if let Some(s) = set {
                tried.push(dir.join(s).join(image));
            }
            tried.push(dir.join(image));
            match tried.iter().find(|p| p.is_file()) {
                Some(p) => Ok(GtImage {
                    key,
                    path: p.clone(),
                    boxes,
                }),
                None => Err(DetEvalError::MissingImage {
                    key,
                    tried: tried
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                }),
            }
        })
        .collect()
}

/// Images and boxes of a box CSV; images are looked up under `images_dir` (default: the CSV's
/// directory).
pub fn load_box_csv(csv: &Path, images_dir: Option<&Path>) -> Result<Vec<GtImage>> {
    let records = parse_box_csv(&read_text(csv)?, csv)?;
    let dir = images_dir
        .map(Path::to_path_buf)
        .unwrap_or_else(|| csv.parent().map(Path::to_path_buf).unwrap_or_default());
    let imgs = images_from_records(&dir, &records)?;
    if imgs.is_empty() {
        return Err(DetEvalError::NoImages {
            what: format!("{} has no boxes", csv.display()),
        });
    }
    Ok(imgs)
}

/// The USC root: `$MOSAICD_DATA/pedestrian/usc` (an error says where to put it when missing).
pub(crate) fn usc_root() -> Result<PathBuf> {
    Ok(crate::data::data_path(USC_DIR)?)
}

/// All USC images with boxes, sorted by key (`USCPedestrianSetA/9Cup10.bmp`, …): Sets A and B from
/// their `NAME.gt.xml` files, Set C from `GT/human_GT.txt`.
pub fn load_usc(root: &Path) -> Result<Vec<GtImage>> {
    let mut records = Vec::new();
    for (set, xml) in USC_SETS {
        let dir = root.join(set);
        if xml {
            let rd = std::fs::read_dir(&dir).map_err(|source| DetEvalError::Io {
                path: dir.clone(),
                source,
            })?;
            let mut files: Vec<PathBuf> = rd
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.to_str().is_some_and(|s| s.ends_with(".gt.xml")))
                .collect();
            files.sort();
            for f in files {
                let stem = f
                    .file_name()
                    .and_then(|n| n.to_str())
                    .and_then(|n| n.strip_suffix(".gt.xml"))
                    .unwrap_or_default()
                    .to_string();
                let image = ["bmp", "BMP", "png", "jpg"]
                    .iter()
                    .map(|e| format!("{stem}.{e}"))
                    .find(|n| dir.join(n).is_file())
                    .ok_or_else(|| DetEvalError::MissingImage {
                        key: format!("{set}/{stem}"),
                        tried: format!("{}/{stem}.bmp", dir.display()),
                    })?;
                for rect in parse_usc_xml(&read_text(&f)?, &f)? {
                    records.push(BoxRecord {
                        set: Some(set.to_string()),
                        image: image.clone(),
                        rect,
                    });
                }
            }
        } else {
            let f = dir.join("GT/human_GT.txt");
            for mut r in parse_human_gt(&read_text(&f)?, &f)? {
                r.set = Some(set.to_string());
                records.push(r);
            }
        }
    }
    images_from_records(root, &records)
}

/// Every `every`-th image (the first, the `every+1`-th, …), then at most `limit` (0 = no limit).
pub(crate) fn subsample(images: Vec<GtImage>, every: usize, limit: usize) -> Result<Vec<GtImage>> {
    let every = every.max(1);
    let mut v: Vec<GtImage> = images.into_iter().step_by(every).collect();
    if limit > 0 {
        v.truncate(limit);
    }
    if v.is_empty() {
        return Err(DetEvalError::NoImages {
            what: format!("every {every}, limit {limit}"),
        });
    }
    Ok(v)
}

/// A box map applied to every detection before matching (fractions of the detection's size).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Shrink {
    /// Left offset as a fraction of the width.
    pub x: f32,
    /// Top offset as a fraction of the height.
    pub y: f32,
    /// New width as a fraction of the width.
    pub width: f32,
    /// New height as a fraction of the height.
    pub height: f32,
}

impl Shrink {
    /// The convention of docs/detection.md: `(x + 0.2w, y + 0.1h, 0.6w, 0.8h)`.
    pub const DOC: Shrink = Shrink {
        x: 0.2,
        y: 0.1,
        width: 0.6,
        height: 0.8,
    };

    /// An image's detections shrunk, its ground truth as it is.
    pub fn apply_image(&self, img: &ImageDetections) -> ImageDetections {
        ImageDetections {
            detections: img.detections.iter().map(|d| self.apply(d)).collect(),
            ground_truth: img.ground_truth.clone(),
        }
    }

    /// The shrunk detection (score unchanged).
    pub fn apply(&self, d: &Detection) -> Detection {
        Detection {
            x: d.x + self.x * d.width,
            y: d.y + self.y * d.height,
            width: self.width * d.width,
            height: self.height * d.height,
            score: d.score,
        }
    }
}

/// Decode an image file as RGB (grey images are replicated into three channels); the trainer's
/// loader, with its error as [`DetEvalError::Decode`].
pub fn load_image_rgb(path: &Path) -> Result<Image<[u8; 3]>> {
    crate::image_io::load_rgb8(path).map_err(|e| DetEvalError::Decode {
        path: e.path,
        reason: e.source.to_string(),
    })
}

/// The detector's view of a domain image (a mosaic sampled or made through `cfa`).
pub(crate) fn people_input(img: &DomainImage, cfa: Cfa) -> PeopleInput<'_> {
    match img {
        DomainImage::Mosaic(m) => PeopleInput::Mosaic { image: m.view(), cfa },
        DomainImage::Grey(g) => PeopleInput::Grey(g.view()),
        DomainImage::Colour(c) => PeopleInput::Colour(c.view()),
    }
}

/// Run `det` (HOG or ACF) on every image (brought into `domain` through `pipeline`; a reverse-ISP
/// mosaic in the model's tone with gains from `wb`); `progress(i, key)` is called before image `i`.
/// Returns the detections with each image's ground truth.
#[allow(clippy::too_many_arguments)]
pub(crate) fn detect_images(
    det: &PeopleDetector,
    images: &[GtImage],
    domain: Domain,
    cfa: Cfa,
    pipeline: &InputPipeline,
    wb: Gains,
    progress: &mut dyn FnMut(usize, &str),
) -> Result<Vec<ImageDetections>> {
    let prep = det.mosaic_prep(wb);
    let mut out = Vec::with_capacity(images.len());
    for (i, g) in images.iter().enumerate() {
        progress(i, &g.key);
        let rgb = load_image_rgb(&g.path)?;
        let img = DomainImage::from_rgb_via(&rgb, domain, cfa, pipeline, i as u64, &prep)?;
        let (dets, _) = det.detect(&people_input(&img, cfa))?;
        out.push(ImageDetections {
            detections: dets,
            ground_truth: g.boxes.clone(),
        });
    }
    Ok(out)
}

/// Parse a detections CSV written by another detector (`image,x,y,w,h,score` with a header; `image`
/// is the key `set/image`), grouped by key.
pub(crate) fn parse_detections_csv(text: &str, origin: &Path) -> Result<BTreeMap<String, Vec<Detection>>> {
    let csv = Csv::parse(text, origin, "image,x,y,w,h,score")?;
    let c = [
        csv.column(&["image"])?,
        csv.column(&["x"])?,
        csv.column(&["y"])?,
        csv.column(&["w", "width"])?,
        csv.column(&["h", "height"])?,
        csv.column(&["score"])?,
    ];
    let mut out: BTreeMap<String, Vec<Detection>> = BTreeMap::new();
    for (n, f) in csv.rows {
        let r = rect_checked(
            origin,
            n,
            number(origin, n, "x", f[c[1]])?,
            number(origin, n, "y", f[c[2]])?,
            number(origin, n, "w", f[c[3]])?,
            number(origin, n, "h", f[c[4]])?,
        )?;
        out.entry(f[c[0]].trim().to_string())
            .or_default()
            .push(Detection {
                x: r.x,
                y: r.y,
                width: r.width,
                height: r.height,
                score: number(origin, n, "score", f[c[5]])?,
            });
    }
    Ok(out)
}

/// Pair external detections with the selected images (images without rows have no detections).
/// Errors when none of the file's keys names a selected image (a mismatched file).
pub(crate) fn external_detections(
    images: &[GtImage],
    dets: &BTreeMap<String, Vec<Detection>>,
    origin: &Path,
) -> Result<Vec<ImageDetections>> {
    if !dets.is_empty() && !images.iter().any(|g| dets.contains_key(&g.key)) {
        return Err(DetEvalError::NoImages {
            what: format!(
                "{} names none of the selected images (keys like {:?}, expected like {:?})",
                origin.display(),
                dets.keys().next().map(String::as_str).unwrap_or(""),
                images.first().map(|g| g.key.as_str()).unwrap_or("")
            ),
        });
    }
    Ok(images
        .iter()
        .map(|g| ImageDetections {
            detections: dets.get(&g.key).cloned().unwrap_or_default(),
            ground_truth: g.boxes.clone(),
        })
        .collect())
}

/// AP, recall and the PR curve of one detector on one image set.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub(crate) struct ApSummary {
    /// Images.
    pub images: usize,
    /// Ground-truth boxes.
    pub boxes: usize,
    /// Detections (after NMS).
    pub detections: usize,
    /// True positives at the loosest threshold.
    pub true_positives: usize,
    /// All-points average precision.
    pub ap: f64,
    /// Recall at the loosest threshold (`true_positives / boxes`).
    pub recall: f64,
    /// Log-average miss rate over FPPI 10⁻² … 10⁰.
    pub lamr: f64,
    /// `(recall, precision)` points, thinned for plotting.
    pub pr: Vec<(f64, f64)>,
}

/// Match (IoU ≥ `iou`) and score `images`, with every detection first mapped by `shrink` if given.
pub(crate) fn ap_summary(images: &[ImageDetections], shrink: Option<Shrink>, iou: f64) -> Result<ApSummary> {
    let mapped: Vec<ImageDetections>;
    let used = match shrink {
        Some(s) => {
            mapped = images.iter().map(|i| s.apply_image(i)).collect();
            &mapped
        }
        None => images,
    };
    let m = match_detections(used, iou)?;
    let r = average_precision(&m, ApMethod::AllPoints)?;
    let tp = m.ranked.iter().filter(|(_, t)| *t).count();
    let stride = (r.recall.len() / PR_PLOT_POINTS).max(1);
    let mut pr: Vec<(f64, f64)> = r
        .recall
        .iter()
        .zip(&r.precision)
        .step_by(stride)
        .map(|(a, b)| (*a, *b))
        .collect();
    if let (Some(&a), Some(&b)) = (r.recall.last(), r.precision.last()) {
        if pr.last() != Some(&(a, b)) {
            pr.push((a, b));
        }
    }
    Ok(ApSummary {
        images: images.len(),
        boxes: m.n_ground_truth,
        detections: m.ranked.len(),
        true_positives: tp,
        ap: r.ap,
        recall: tp as f64 / m.n_ground_truth as f64,
        lamr: log_average_miss_rate(&mr_fppi_curve(&m)?),
        pr,
    })
}

/// Draw precision vs recall curves (one per named summary) to a PNG.
pub(crate) fn pr_plot(title: &str, curves: &[(String, &ApSummary)], path: &Path) -> Result<()> {
    let mut p = LinePlot {
        title: title.into(),
        x_label: "recall".into(),
        y_label: "precision".into(),
        x_range: Some((0.0, 1.0)),
        y_range: Some((0.0, 1.0)),
        legend: Legend::LowerLeft,
        ..LinePlot::default()
    };
    for (name, s) in curves {
        p = p.with_series(Series::new(format!("{name} (AP {:.3})", s.ap), s.pr.clone()));
    }
    Ok(line_plot(&p, path)?)
}

/// Draw DET curves (miss rate vs FPPW, log–log) to a PNG.
pub(crate) fn det_plot(title: &str, curves: &[(String, &[DetPoint])], path: &Path) -> Result<()> {
    let mut p = LinePlot {
        title: title.into(),
        x_label: "false positives per window (FPPW)".into(),
        y_label: "miss rate".into(),
        x_scale: Scale::Log10,
        y_scale: Scale::Log10,
        x_range: Some((1e-6, 1e-1)),
        y_range: Some((1e-2, 1.0)),
        legend: Legend::LowerLeft,
        ..LinePlot::default()
    };
    for (name, c) in curves {
        p = p.with_series(Series::new(
            name.clone(),
            c.iter()
                .filter(|q| q.fppw > 0.0)
                .map(|q| (q.fppw, q.miss_rate))
                .collect(),
        ));
    }
    Ok(line_plot(&p, path)?)
}

/// Write detections as the CSV that [`parse_detections_csv`] (and `--external`) reads:
/// `image,x,y,w,h,score`, one row per detection, images in the order given.
pub(crate) fn detections_csv(images: &[GtImage], dets: &[ImageDetections]) -> String {
    let mut s = String::from("image,x,y,w,h,score\n");
    for (g, d) in images.iter().zip(dets) {
        for b in &d.detections {
            s.push_str(&format!(
                "{},{},{},{},{},{}\n",
                g.key, b.x, b.y, b.width, b.height, b.score
            ));
        }
    }
    s
}

/// One detector's detections at one pyramid phase, matched image by image, ready to be scored on
/// any resample of the images (matching is per image, only the ranking is global).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PerImageMatches {
    /// `(score, true_positive)` of every detection of each image.
    pub per_image: Vec<Vec<(f32, bool)>>,
    /// Ground-truth boxes of each image.
    pub ground_truth: Vec<usize>,
}

impl PerImageMatches {
    /// Match every image on its own (IoU ≥ `iou`), detections first mapped by `shrink` if given.
    pub(crate) fn new(images: &[ImageDetections], shrink: Option<Shrink>, iou: f64) -> Result<Self> {
        let mut per_image = Vec::with_capacity(images.len());
        let mut ground_truth = Vec::with_capacity(images.len());
        for img in images {
            let one = match shrink {
                Some(s) => s.apply_image(img),
                None => img.clone(),
            };
            let m = match_detections(std::slice::from_ref(&one), iou)?;
            per_image.push(m.ranked);
            ground_truth.push(m.n_ground_truth);
        }
        Ok(Self {
            per_image,
            ground_truth,
        })
    }

    /// The matched detections of the images `idx` (repeats allowed), ranked by score; ties keep
    /// the order of `idx`. Equal to `match_detections` of those images.
    pub(crate) fn resample(&self, idx: &[usize]) -> MatchedDetections {
        let mut ranked: Vec<(f32, bool)> = idx
            .iter()
            .flat_map(|&i| self.per_image[i].iter().copied())
            .collect();
        ranked.sort_by(|a, b| b.0.total_cmp(&a.0));
        MatchedDetections {
            ranked,
            n_ground_truth: idx.iter().map(|&i| self.ground_truth[i]).sum(),
            n_images: idx.len(),
        }
    }

    /// All-points AP and log-average miss rate of the images `idx`.
    pub(crate) fn ap_lamr(&self, idx: &[usize]) -> Result<(f64, f64)> {
        let m = self.resample(idx);
        let ap = average_precision(&m, ApMethod::AllPoints)?.ap;
        let lamr = log_average_miss_rate(&mr_fppi_curve(&m)?);
        Ok((ap, lamr))
    }
}

/// One detector's paired-bootstrap result (all values are means over the phases).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub(crate) struct BootstrapRow {
    /// 95 % interval of AP.
    pub ap: Interval,
    /// 95 % interval of the log-average miss rate.
    pub lamr: Interval,
    /// 95 % interval of AP minus the reference detector's AP on the same resample.
    pub ap_diff: Interval,
    /// 95 % interval of LAMR minus the reference detector's.
    pub lamr_diff: Interval,
    /// Fraction of resamples in which this detector's AP is at least the reference's.
    pub ap_not_worse: f64,
}

/// Paired bootstrap over images: `rows[r][p]` is detector `r` at phase `p`, all over the same
/// images. Each of `resamples` draws (seeded `ChaCha8`, so the result is reproducible) takes the
/// images with replacement, scores every detector at every phase on them, averages AP and LAMR
/// over the phases, and differences them from row `reference`. A draw whose images hold no
/// ground-truth box is redrawn.
///
/// The interval is the 2.5–97.5 % percentile interval of the draws; it describes the variation
/// over *images* (the phases are fixed), so it is the uncertainty of "on people like these",
/// not of the pyramid's phase.
pub(crate) fn paired_bootstrap(
    rows: &[Vec<PerImageMatches>],
    reference: usize,
    resamples: usize,
    seed: u64,
) -> Result<Vec<BootstrapRow>> {
    use rand::{Rng, SeedableRng};
    let n = rows
        .first()
        .and_then(|r| r.first())
        .map_or(0, |m| m.per_image.len());
    if n == 0 || resamples == 0 {
        return Err(DetEvalError::NoImages {
            what: format!("bootstrap over {n} images with {resamples} resamples"),
        });
    }
    if rows.iter().flatten().any(|m| m.per_image.len() != n) || rows.iter().any(|r| r.is_empty()) {
        return Err(DetEvalError::NoImages {
            what: "bootstrap rows over different image sets".into(),
        });
    }
    if reference >= rows.len() {
        return Err(DetEvalError::NoImages {
            what: format!("bootstrap reference row {reference} of {} rows", rows.len()),
        });
    }
    let total_gt: usize = rows[0][0].ground_truth.iter().sum();
    if total_gt == 0 {
        return Err(crate::metrics::MetricsError::NoSamples { what: "ground truth" }.into());
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    // draws[r] = (ap, lamr) per resample.
    let mut draws: Vec<Vec<(f64, f64)>> = vec![Vec::with_capacity(resamples); rows.len()];
    let mut idx = vec![0usize; n];
    for _ in 0..resamples {
        loop {
            idx.iter_mut().for_each(|i| *i = rng.random_range(0..n));
            if idx.iter().any(|&i| rows[0][0].ground_truth[i] > 0) {
                break;
            }
        }
        for (r, phases) in rows.iter().enumerate() {
            let (mut ap, mut lamr) = (0.0, 0.0);
            for m in phases {
                let (a, l) = m.ap_lamr(&idx)?;
                ap += a;
                lamr += l;
            }
            let k = phases.len() as f64;
            draws[r].push((ap / k, lamr / k));
        }
    }
    Ok(draws
        .iter()
        .map(|d| {
            let reference = &draws[reference];
            BootstrapRow {
                ap: Interval::of(d.iter().map(|x| x.0).collect()),
                lamr: Interval::of(d.iter().map(|x| x.1).collect()),
                ap_diff: Interval::of(d.iter().zip(reference).map(|(x, y)| x.0 - y.0).collect()),
                lamr_diff: Interval::of(d.iter().zip(reference).map(|(x, y)| x.1 - y.1).collect()),
                ap_not_worse: d.iter().zip(reference).filter(|(x, y)| x.0 >= y.0).count() as f64
                    / resamples as f64,
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::detection::tests::{det, rect};
    use crate::metrics::detection::PASCAL_IOU;

    fn one(dets: Vec<Detection>, gt: Vec<Rect>) -> Vec<ImageDetections> {
        vec![ImageDetections {
            detections: dets,
            ground_truth: gt,
        }]
    }

    #[test]
    fn ap_perfect_detector_is_one() {
        let gt = vec![rect(0.0, 0.0, 10.0, 20.0), rect(30.0, 0.0, 10.0, 20.0)];
        let s = ap_summary(
            &one(
                vec![det(0.0, 0.0, 10.0, 20.0, 2.0), det(30.0, 0.0, 10.0, 20.0, 1.0)],
                gt,
            ),
            None,
            PASCAL_IOU,
        )
        .unwrap();
        assert_eq!((s.ap, s.recall, s.true_positives), (1.0, 1.0, 2));
    }

    #[test]
    fn ap_false_positive_ranked_first() {
        // Ranked: FP, TP, TP → precision 0, 1/2, 2/3 at recall 0, 1/2, 1; envelope 2/3 everywhere:
        // AP = 1/2·2/3 + 1/2·2/3 = 2/3.
        let gt = vec![rect(0.0, 0.0, 10.0, 20.0), rect(30.0, 0.0, 10.0, 20.0)];
        let dets = vec![
            det(100.0, 0.0, 10.0, 20.0, 3.0),
            det(0.0, 0.0, 10.0, 20.0, 2.0),
            det(30.0, 0.0, 10.0, 20.0, 1.0),
        ];
        let s = ap_summary(&one(dets, gt), None, PASCAL_IOU).unwrap();
        assert!((s.ap - 2.0 / 3.0).abs() < 1e-12, "{}", s.ap);
        assert_eq!(s.recall, 1.0);
    }

    #[test]
    fn ap_duplicates_are_false_positives() {
        // Two detections on the one box: TP then FP. precision 1, 1/2; recall 1/2, 1/2 (second box
        // never found) → AP = 1/2.
        let gt = vec![rect(0.0, 0.0, 10.0, 20.0), rect(30.0, 0.0, 10.0, 20.0)];
        let dets = vec![det(0.0, 0.0, 10.0, 20.0, 2.0), det(1.0, 0.0, 10.0, 20.0, 1.0)];
        let s = ap_summary(&one(dets, gt), None, PASCAL_IOU).unwrap();
        assert!((s.ap - 0.5).abs() < 1e-12, "{}", s.ap);
        assert_eq!((s.true_positives, s.detections), (1, 2));
    }

    #[test]
    fn ap_no_detections_is_zero() {
        let s = ap_summary(&one(vec![], vec![rect(0.0, 0.0, 10.0, 20.0)]), None, PASCAL_IOU).unwrap();
        assert_eq!((s.ap, s.recall, s.detections), (0.0, 0.0, 0));
    }

    #[test]
    fn shrink_turns_a_window_into_a_match() {
        // A 64x128 window around a tight 38x102 box: IoU 0.48 raw, 1.0 after the DOC shrink.
        let gt = vec![rect(12.8, 12.8, 38.4, 102.4)];
        let dets = vec![det(0.0, 0.0, 64.0, 128.0, 1.0)];
        assert_eq!(
            ap_summary(&one(dets.clone(), gt.clone()), None, PASCAL_IOU)
                .unwrap()
                .ap,
            0.0
        );
        let s = ap_summary(&one(dets, gt), Some(Shrink::DOC), PASCAL_IOU).unwrap();
        assert_eq!(s.ap, 1.0);
    }

    #[test]
    fn box_csv_parses_and_names_bad_lines() {
        let p = Path::new("usc.csv");
        let csv = "set,image,img_w,img_h,x,y,w,h\nA,a.bmp,424,117,2,17,33,81\n\nB,b.bmp,10,10,1.5,2,3,4\n";
        let r = parse_box_csv(csv, p).unwrap();
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].key(), "A/a.bmp");
        assert_eq!(r[0].rect, rect(2.0, 17.0, 33.0, 81.0));
        assert_eq!(r[1].rect.x, 1.5);
        // Without a set column the key is the file name; width/height spelled out.
        let r = parse_box_csv("image,x,y,width,height\nz.png,0,0,5,6\n", p).unwrap();
        assert_eq!((r[0].key(), r[0].rect.height), ("z.png".to_string(), 6.0));
        for (bad, line, what) in [
            ("image,x,y,w,h\na.png,1,2,3,4\na.png,1,2,x,4\n", 3, "not a number"),
            ("image,x,y,w,h\na.png,1,2,3\n", 2, "4 fields"),
            ("image,x,y,w,h\na.png,1,2,0,4\n", 2, "must be positive"),
            ("image,x,y,w\na.png,1,2,3\n", 1, "`h` column"),
            ("", 1, "empty file"),
        ] {
            let e = parse_box_csv(bad, p).unwrap_err().to_string();
            assert!(e.starts_with(&format!("usc.csv:{line}: ")), "{e}");
            assert!(e.contains(what), "{e}");
        }
    }

    #[test]
    fn usc_xml_parses_and_names_bad_lines() {
        let p = Path::new("a.gt.xml");
        let xml = "<?xml version=\"1.0\"?>\n<ObjectList>\n\t<Object>\n\t\t<Rect x=\"2\" y=\"17\" width=\"33\" height=\"81\"/>\n\t</Object>\n\t<Object>\n\t\t<Rect height='7' width='5' y='4' x='3'/>\n\t</Object>\n</ObjectList>\n";
        assert_eq!(
            parse_usc_xml(xml, p).unwrap(),
            vec![rect(2.0, 17.0, 33.0, 81.0), rect(3.0, 4.0, 5.0, 7.0)]
        );
        assert!(parse_usc_xml("<ObjectList>\n</ObjectList>", p)
            .unwrap()
            .is_empty());
        let e = parse_usc_xml("<ObjectList>\n\n<Rect x=\"1\" y=\"2\" width=\"3\"/>", p)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("a.gt.xml:3: ") && e.contains("`height`"), "{e}");
        let e = parse_usc_xml("<ObjectList><Rect x=\"a\" y=\"2\" width=\"3\" height=\"4\"/>", p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("x = \"a\""), "{e}");
        assert!(parse_usc_xml("hello", p).is_err());
    }

    #[test]
    fn human_gt_parses_and_names_bad_lines() {
        let p = Path::new("human_GT.txt");
        let t = "10-08-00c-00.bmp 10 44 28 112\n\nWALK_107.BMP 26 76 29 99\n";
        let r = parse_human_gt(t, p).unwrap();
        assert_eq!(r.len(), 2);
        assert_eq!(
            (r[1].image.as_str(), r[1].rect),
            ("WALK_107.BMP", rect(26.0, 76.0, 29.0, 99.0))
        );
        let e = parse_human_gt("a.bmp 1 2 3 4\nb.bmp 1 2 3\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("human_GT.txt:2: ") && e.contains("4 fields"), "{e}");
    }

    #[test]
    fn detections_csv_and_external_pairing() {
        let p = Path::new("cv.csv");
        let d = parse_detections_csv(
            "image,x,y,w,h,score\nS/a.bmp,1,2,3,4,0.5\nS/a.bmp,5,6,7,8,-0.2\n",
            p,
        )
        .unwrap();
        assert_eq!(d["S/a.bmp"].len(), 2);
        assert_eq!(d["S/a.bmp"][1].score, -0.2);
        let imgs = vec![
            GtImage {
                key: "S/a.bmp".into(),
                path: PathBuf::from("a.bmp"),
                boxes: vec![rect(1.0, 2.0, 3.0, 4.0)],
            },
            GtImage {
                key: "S/b.bmp".into(),
                path: PathBuf::from("b.bmp"),
                boxes: vec![rect(1.0, 2.0, 3.0, 4.0)],
            },
        ];
        let e = external_detections(&imgs, &d, p).unwrap();
        assert_eq!((e[0].detections.len(), e[1].detections.len()), (2, 0));
        let other = parse_detections_csv("image,x,y,w,h,score\nT/z.bmp,1,2,3,4,1\n", p).unwrap();
        assert!(external_detections(&imgs, &other, p).is_err());
        let e = parse_detections_csv("image,x,y,w,h\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("`score` column"), "{e}");
    }

    #[test]
    fn subsample_every_and_limit() {
        let imgs: Vec<GtImage> = (0..10)
            .map(|i| GtImage {
                key: format!("{i}"),
                path: PathBuf::new(),
                boxes: vec![],
            })
            .collect();
        let keys = |v: Vec<GtImage>| v.into_iter().map(|g| g.key).collect::<Vec<_>>().join(",");
        assert_eq!(keys(subsample(imgs.clone(), 3, 0).unwrap()), "0,3,6,9");
        assert_eq!(keys(subsample(imgs.clone(), 3, 2).unwrap()), "0,3");
        assert!(subsample(vec![], 1, 0).is_err());
    }
    /// `n` images with one box each; detector `good` finds every box, `flaky` finds every
    /// other one, and both put one false positive in every image at a mid score.
    fn bootstrap_fixture(n: usize) -> (Vec<ImageDetections>, Vec<ImageDetections>) {
        let gt = rect(0.0, 0.0, 10.0, 20.0);
        let fp = det(50.0, 0.0, 10.0, 20.0, 0.5);
        let mk = |hit: bool, i: usize| ImageDetections {
            detections: if hit {
                vec![det(0.0, 0.0, 10.0, 20.0, 1.0 + i as f32 * 1e-3), fp]
            } else {
                vec![fp]
            },
            ground_truth: vec![gt],
        };
        let good = (0..n).map(|i| mk(true, i)).collect();
        let flaky = (0..n).map(|i| mk(i % 2 == 0, i)).collect();
        (good, flaky)
    }

    #[test]
    fn per_image_matches_resample_equals_matching_the_resampled_images() {
        let (good, flaky) = bootstrap_fixture(9);
        for set in [good, flaky] {
            let m = PerImageMatches::new(&set, None, PASCAL_IOU).unwrap();
            let idx = [3, 3, 0, 8, 5, 5, 5, 1, 2];
            let picked: Vec<ImageDetections> = idx.iter().map(|&i| set[i].clone()).collect();
            assert_eq!(m.resample(&idx), match_detections(&picked, PASCAL_IOU).unwrap());
            let all: Vec<usize> = (0..9).collect();
            let (ap, _) = m.ap_lamr(&all).unwrap();
            assert_eq!(ap, pascal_ap_of(&set));
        }
    }

    fn pascal_ap_of(set: &[ImageDetections]) -> f64 {
        crate::metrics::detection::pascal_ap(set).unwrap().ap
    }

    #[test]
    fn paired_bootstrap_separates_a_better_detector_and_is_reproducible() {
        let (good, flaky) = bootstrap_fixture(40);
        let rows = vec![
            vec![PerImageMatches::new(&flaky, None, PASCAL_IOU).unwrap()],
            vec![PerImageMatches::new(&good, None, PASCAL_IOU).unwrap()],
            vec![PerImageMatches::new(&flaky, None, PASCAL_IOU).unwrap()],
        ];
        let b = paired_bootstrap(&rows, 0, 200, 7).unwrap();
        assert_eq!(b, paired_bootstrap(&rows, 0, 200, 7).unwrap());
        // The reference against itself: a zero difference on every draw.
        assert_eq!((b[0].ap_diff.lo, b[0].ap_diff.hi), (0.0, 0.0));
        assert_eq!(b[0].ap_not_worse, 1.0);
        assert_eq!(b[2], b[0]);
        // `good` (AP 1) is ahead of `flaky` on every draw, by an interval that excludes 0.
        assert_eq!(b[1].ap_not_worse, 1.0);
        assert!(b[1].ap_diff.lo > 0.2, "{:?}", b[1]);
        assert!(b[1].lamr_diff.hi < 0.0, "{:?}", b[1]);
        assert_eq!((b[1].ap.lo, b[1].ap.hi), (1.0, 1.0));
        // The point estimate of `flaky` lies inside its interval.
        let all: Vec<usize> = (0..40).collect();
        let (ap, lamr) = rows[0][0].ap_lamr(&all).unwrap();
        assert!(b[0].ap.lo <= ap && ap <= b[0].ap.hi, "{ap} {:?}", b[0].ap);
        assert!(b[0].lamr.lo <= lamr && lamr <= b[0].lamr.hi);
        assert!(b[0].ap.lo < b[0].ap.hi);
        // Another reference: same draws, differences taken from it.
        let c = paired_bootstrap(&rows, 1, 200, 7).unwrap();
        assert_eq!((c[1].ap_diff.lo, c[1].ap_diff.hi), (0.0, 0.0));
        assert_eq!(c[0].ap, b[0].ap);
        assert!(c[0].ap_diff.hi < -0.2, "{:?}", c[0]);
        assert_eq!(c[0].ap_not_worse, 0.0);
        // Phases are averaged: the reference at two phases (flaky, good) sits between them.
        let two = vec![
            vec![
                PerImageMatches::new(&flaky, None, PASCAL_IOU).unwrap(),
                PerImageMatches::new(&good, None, PASCAL_IOU).unwrap(),
            ],
            vec![
                PerImageMatches::new(&good, None, PASCAL_IOU).unwrap(),
                PerImageMatches::new(&good, None, PASCAL_IOU).unwrap(),
            ],
        ];
        let t = paired_bootstrap(&two, 0, 100, 1).unwrap();
        assert!(t[0].ap.hi < 1.0 && t[0].ap.lo > b[0].ap.lo, "{:?}", t[0]);
    }

    #[test]
    fn paired_bootstrap_rejects_mismatched_or_empty_input() {
        let (good, _) = bootstrap_fixture(5);
        let m = PerImageMatches::new(&good, None, PASCAL_IOU).unwrap();
        let short = PerImageMatches::new(&good[..3], None, PASCAL_IOU).unwrap();
        assert!(paired_bootstrap(&[vec![m.clone()], vec![short]], 0, 10, 1).is_err());
        assert!(paired_bootstrap(&[vec![m.clone()]], 0, 0, 1).is_err());
        assert!(paired_bootstrap(&[], 0, 10, 1).is_err());
        assert!(paired_bootstrap(&[vec![m.clone()]], 1, 10, 1).is_err());
        let no_gt = vec![ImageDetections::default(); 4];
        let e = PerImageMatches::new(&no_gt, None, PASCAL_IOU).unwrap();
        let err = paired_bootstrap(&[vec![e]], 0, 10, 1).unwrap_err();
        assert!(err.to_string().contains("ground truth"), "{err}");
    }

    #[test]
    fn detections_csv_round_trips_through_the_external_reader() {
        let (good, _) = bootstrap_fixture(3);
        let images: Vec<GtImage> = (0..3)
            .map(|i| GtImage {
                key: format!("SetA/im{i}.bmp"),
                path: PathBuf::from(format!("im{i}.bmp")),
                boxes: good[i].ground_truth.clone(),
            })
            .collect();
        let text = detections_csv(&images, &good);
        let back = external_detections(
            &images,
            &parse_detections_csv(&text, Path::new("d.csv")).unwrap(),
            Path::new("d.csv"),
        )
        .unwrap();
        assert_eq!(back, good);
    }
}
