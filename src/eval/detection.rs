//! Full-image detection evaluation: ground-truth boxes (USC Pedestrian Sets A/B/C or any directory
//! with a box CSV), the detector run over every image, greedy PASCAL matching at IoU ≥ 0.5, average
//! precision, recall and precision/recall curves; plus the DET and PR plots of `mosaicd eval
//! detection`.
//!
//! ```
//! use mosaicd::eval::detection::{parse_box_csv, Shrink};
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
//! [`crate::metrics::detection::match_detections`]: detections of all images sorted by score, each
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

use crate::detect::train::{DomainImage, InputPipeline};
use crate::detect::{Detection, Detector, Domain};
use crate::eval::plot::{line_plot, Legend, LinePlot, Scale, Series};
use crate::image::Image;
use crate::metrics::detection::{
    average_precision, match_detections, ApMethod, DetPoint, ImageDetections, Rect,
};
use crate::raw::Cfa;

/// USC data directory relative to the data root.
pub const USC_DIR: &str = "pedestrian/usc";
/// The USC sets read by [`load_usc`], in order, and whether their boxes are in per-image XML files
/// (`true`) or in `GT/human_GT.txt` (`false`).
pub const USC_SETS: [(&str, bool); 3] = [
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
    /// Bringing an image into the model's domain failed.
    #[error(transparent)]
    Input(#[from] crate::detect::train::TrainError),
    /// A metric failed.
    #[error(transparent)]
    Metrics(#[from] crate::metrics::MetricsError),
    /// A plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] crate::eval::plot::PlotError),
}

/// Result alias of this module.
pub type Result<T> = std::result::Result<T, DetEvalError>;

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
pub fn parse_usc_xml(text: &str, origin: &Path) -> Result<Vec<Rect>> {
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
pub fn parse_human_gt(text: &str, origin: &Path) -> Result<Vec<BoxRecord>> {
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
pub fn images_from_records(dir: &Path, records: &[BoxRecord]) -> Result<Vec<GtImage>> {
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
pub fn usc_root() -> Result<PathBuf> {
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
pub fn subsample(images: Vec<GtImage>, every: usize, limit: usize) -> Result<Vec<GtImage>> {
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
    crate::detect::train::load_rgb(path).map_err(|e| match e {
        crate::detect::train::TrainError::Data { path, what } => DetEvalError::Decode { path, reason: what },
        e => DetEvalError::Input(e),
    })
}

/// Run `det` on every image (brought into `domain` through `pipeline`); `progress(i, key)` is called
/// before image `i`. Returns the detections with each image's ground truth.
pub fn detect_images(
    det: &Detector,
    images: &[GtImage],
    domain: Domain,
    cfa: Cfa,
    pipeline: &InputPipeline,
    progress: &mut dyn FnMut(usize, &str),
) -> Result<Vec<ImageDetections>> {
    let mut out = Vec::with_capacity(images.len());
    for (i, g) in images.iter().enumerate() {
        progress(i, &g.key);
        let rgb = load_image_rgb(&g.path)?;
        let img = DomainImage::from_rgb_via(&rgb, domain, cfa, pipeline, i as u64)?;
        let (dets, _) = det.detect(&img.input())?;
        out.push(ImageDetections {
            detections: dets,
            ground_truth: g.boxes.clone(),
        });
    }
    Ok(out)
}

/// Parse a detections CSV written by another detector (`image,x,y,w,h,score` with a header; `image`
/// is the key `set/image`), grouped by key.
pub fn parse_detections_csv(text: &str, origin: &Path) -> Result<BTreeMap<String, Vec<Detection>>> {
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
pub fn external_detections(
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
pub struct ApSummary {
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
    /// `(recall, precision)` points, thinned for plotting.
    pub pr: Vec<(f64, f64)>,
}

/// Match (IoU ≥ `iou`) and score `images`, with every detection first mapped by `shrink` if given.
pub fn ap_summary(images: &[ImageDetections], shrink: Option<Shrink>, iou: f64) -> Result<ApSummary> {
    let mapped: Vec<ImageDetections>;
    let used = match shrink {
        Some(s) => {
            mapped = images
                .iter()
                .map(|i| ImageDetections {
                    detections: i.detections.iter().map(|d| s.apply(d)).collect(),
                    ground_truth: i.ground_truth.clone(),
                })
                .collect();
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
        pr,
    })
}

/// Draw precision vs recall curves (one per named summary) to a PNG.
pub fn pr_plot(title: &str, curves: &[(String, &ApSummary)], path: &Path) -> Result<()> {
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
pub fn det_plot(title: &str, curves: &[(String, &[DetPoint])], path: &Path) -> Result<()> {
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
}
