//! [`FileSource`]: a directory or list of raw files played as a stream.
//!
//! Each file is read by [`crate::raw::load::load_input`]: camera raw files through rawloader,
//! mosaic PNG/PGM, RGB images (resampled to a mosaic), and **headerless** raw files described by a
//! small TOML sidecar ([`Sidecar`], parsed into the loader's [`RawFormat`]), looked up in this order: `--sidecar` given in the options,
//! `<file>.toml` (e.g. `frame.raw.toml`), `<stem>.toml`, then `mosaicd-raw.toml` in the file's
//! directory. A sidecar looks like:
//!
//! ```toml
//! width = 2592
//! height = 1536
//! bit_depth = 8
//! cfa = "GRBG"        # physical: the pattern at (0, 0)
//! black = 12          # or [b00, b01, b10, b11] per 2x2 tile position
//! white = 255
//! endian = "little"   # 16-bit containers only
//! # stride_bytes = 5184
//! ```
//!
//! Frames are numbered densely; `timestamp_ns = sequence · 1e9 / fps` (recorded-style time, never
//! the wall clock, so a replay is deterministic); with `pace` the source also waits for that time
//! on the injected [`Clock`]. A file that fails to load is reported as an error for that frame and
//! the stream goes on with the next file. `SourceKind::Replay`.
//!
//! ```
//! use mosaicd::capture::{FileSource, FileSourceOptions};
//! use mosaicd::capture::Source;
//! let dir = tempfile::tempdir().unwrap();
//! std::fs::write(dir.path().join("a.raw"), [10u8, 20, 30, 40]).unwrap();
//! std::fs::write(dir.path().join("mosaicd-raw.toml"), "width = 2\nheight = 2\nbit_depth = 8\ncfa = \"RGGB\"\n").unwrap();
//! let mut src = FileSource::open(&[dir.path().to_path_buf()], FileSourceOptions::default()).unwrap();
//! let f = src.next_frame().unwrap().unwrap();
//! assert_eq!(f.to_u16_vec(), vec![10, 20, 30, 40]);
//! assert!(src.next_frame().unwrap().is_none());
//! ```

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Deserialize;

use super::{CaptureError, Clock, MonotonicClock, Source, SourceKind};
use crate::raw::load::{
    headerless_format, load_headerless, load_input, Container, Endian, InputOptions, RawFormat,
};
use crate::raw::{Cfa, RawFrame};

/// Directory-wide sidecar name.
pub const DIR_SIDECAR: &str = "mosaicd-raw.toml";
/// Default stream rate (frames/s) for timestamps.
pub const DEFAULT_FPS: f64 = 30.0;
/// Extensions that are never frames (sidecars, notes, configs).
const NOT_FRAMES: [&str; 8] = ["toml", "json", "md", "txt", "yml", "yaml", "csv", "xml"];

/// A black level: one value, or one per 2x2 tile position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(untagged)]
pub enum Black {
    /// Same everywhere.
    One(u16),
    /// Per tile position `(y&1)*2 + (x&1)`.
    PerPosition([u16; 4]),
}

/// The TOML sidecar of headerless raw files.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sidecar {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Significant bits (8..=16).
    pub bit_depth: u8,
    /// Physical pattern at (0, 0).
    pub cfa: String,
    /// Black level.
    pub black: Option<Black>,
    /// White level (default full scale).
    pub white: Option<u16>,
    /// `"little"` (default) or `"big"`.
    pub endian: Option<String>,
    /// Row stride in bytes.
    pub stride_bytes: Option<usize>,
    /// `"u8"` or `"u16"` (default from the bit depth).
    pub container: Option<String>,
}

impl Sidecar {
    /// Read a sidecar file and parse it into the headerless format it describes.
    pub fn read(path: &Path) -> Result<RawFormat, CaptureError> {
        Self::load(path)?.format(path)
    }

    /// Read a sidecar file as written (checked: its [`Sidecar::format`] is valid).
    pub fn load(path: &Path) -> Result<Self, CaptureError> {
        let text = std::fs::read_to_string(path).map_err(|source| CaptureError::Io {
            context: format!("cannot read sidecar {}", path.display()),
            source,
        })?;
        let s: Sidecar = toml::from_str(&text).map_err(|source| CaptureError::Sidecar {
            path: path.to_path_buf(),
            source: Box::new(source),
        })?;
        s.format(path)?;
        Ok(s)
    }

    /// The headerless format this sidecar describes (the one [`RawFormat`] type of
    /// [`load_input`](crate::raw::load_input); defaults as there: container from the bit depth, black 0, white full
    /// scale). `path` names the sidecar in errors.
    pub fn format(&self, path: &Path) -> Result<RawFormat, CaptureError> {
        let bad = |key: &'static str, value: String, why: &'static str| CaptureError::SidecarValue {
            path: path.to_path_buf(),
            key,
            value,
            why,
        };
        let cfa: Cfa = self
            .cfa
            .parse()
            .map_err(|_| bad("cfa", self.cfa.clone(), "RGGB, BGGR, GRBG or GBRG"))?;
        if !(8..=16).contains(&self.bit_depth) {
            return Err(bad("bit_depth", self.bit_depth.to_string(), "8..=16"));
        }
        let endian = match self.endian.as_deref() {
            None | Some("little") => Endian::Little,
            Some("big") => Endian::Big,
            Some(o) => return Err(bad("endian", o.into(), "\"little\" or \"big\"")),
        };
        let container = match self.container.as_deref() {
            None => None,
            Some("u8") => Some(Container::U8),
            Some("u16") => Some(Container::U16),
            Some(o) => return Err(bad("container", o.into(), "\"u8\" or \"u16\"")),
        };
        let opts = InputOptions {
            width: Some(self.width),
            height: Some(self.height),
            bit_depth: Some(self.bit_depth),
            cfa: Some(cfa),
            black: self.black.map(|b| match b {
                Black::One(v) => [v; 4],
                Black::PerPosition(a) => a,
            }),
            white: self.white,
            endian,
            stride_bytes: self.stride_bytes,
            container,
        };
        // Every field headerless_format needs is set: it cannot fail on this input, but its
        // error is passed on rather than unwrapped.
        Ok(headerless_format(path, &opts)?)
    }
}

/// How one file is read: the format of its sidecar, or the loader options.
#[derive(Debug, Clone, Copy)]
enum HowToRead {
    Headerless(RawFormat),
    Options(InputOptions),
}

/// File source options.
#[derive(Debug, Clone)]
pub struct FileSourceOptions {
    /// Stream rate for timestamps (and pacing), frames/s.
    pub fps: f64,
    /// Wait for each frame's time on the clock (else as fast as possible).
    pub pace: bool,
    /// Start again after the last file.
    pub looped: bool,
    /// A sidecar for every file (overrides per-file sidecars).
    pub sidecar: Option<PathBuf>,
    /// Loader options for files without a sidecar (e.g. the CFA for mosaic PNGs).
    pub input: InputOptions,
    /// Clock for pacing.
    pub clock: Arc<dyn Clock>,
}

impl Default for FileSourceOptions {
    fn default() -> Self {
        Self {
            fps: DEFAULT_FPS,
            pace: false,
            looped: false,
            sidecar: None,
            input: InputOptions::default(),
            clock: Arc::new(MonotonicClock::new()),
        }
    }
}

/// Plays files as a stream.
#[derive(Debug)]
pub struct FileSource {
    files: Vec<PathBuf>,
    opts: FileSourceOptions,
    global: Option<RawFormat>,
    next: usize,
    sequence: u64,
    anchor: Option<u64>,
    finished: bool,
    /// Frames delivered since the current pass over the files began.
    pass_frames: u64,
}

fn is_frame_file(p: &Path) -> bool {
    let hidden = p
        .file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.starts_with('.'));
    let ext = p
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    p.is_file() && !hidden && !NOT_FRAMES.contains(&ext.as_str())
}

impl FileSource {
    /// A stream over `inputs`: files in the given order, directories expanded to their frame
    /// files sorted by name. Fails when nothing is left or an input does not exist.
    pub fn open(inputs: &[PathBuf], opts: FileSourceOptions) -> Result<Self, CaptureError> {
        if !(opts.fps > 0.0 && opts.fps.is_finite()) {
            return Err(CaptureError::Option {
                name: "fps",
                value: opts.fps.to_string(),
                why: "a finite number > 0",
            });
        }
        let mut files = Vec::new();
        for p in inputs {
            if p.is_dir() {
                let rd = std::fs::read_dir(p).map_err(|source| CaptureError::Io {
                    context: format!("cannot list {}", p.display()),
                    source,
                })?;
                let mut v: Vec<PathBuf> = rd
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| is_frame_file(p))
                    .collect();
                v.sort();
                files.extend(v);
            } else if p.is_file() {
                files.push(p.clone());
            } else {
                return Err(CaptureError::Io {
                    context: format!("input {}", p.display()),
                    source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or directory"),
                });
            }
        }
        if files.is_empty() {
            return Err(CaptureError::Option {
                name: "inputs",
                value: format!("{inputs:?}"),
                why: "at least one frame file",
            });
        }
        let global = match &opts.sidecar {
            Some(s) => Some(Sidecar::read(s)?),
            None => None,
        };
        Ok(Self {
            files,
            opts,
            global,
            next: 0,
            sequence: 0,
            anchor: None,
            finished: false,
            pass_frames: 0,
        })
    }

    /// The files in play order.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    /// How to read `path`: global sidecar, per-file sidecar, directory sidecar, or the options'
    /// defaults.
    fn how_to_read(&self, path: &Path) -> Result<HowToRead, CaptureError> {
        if let Some(g) = self.global {
            return Ok(HowToRead::Headerless(g));
        }
        let mut candidates = vec![
            PathBuf::from(format!("{}.toml", path.display())),
            path.with_extension("toml"),
        ];
        if let Some(dir) = path.parent() {
            candidates.push(dir.join(DIR_SIDECAR));
        }
        for c in candidates {
            if c.is_file() {
                return Ok(HowToRead::Headerless(Sidecar::read(&c)?));
            }
        }
        Ok(HowToRead::Options(self.opts.input))
    }
}

impl Source for FileSource {
    fn next_frame(&mut self) -> Result<Option<RawFrame>, CaptureError> {
        if self.finished {
            return Ok(None);
        }
        if self.next >= self.files.len() {
            if !self.opts.looped {
                self.finished = true;
                return Ok(None);
            }
            if self.pass_frames == 0 {
                // Every file failed: looping again would only repeat the same errors.
                self.finished = true;
                return Err(CaptureError::NothingPlayable {
                    what: self.describe(),
                    files: self.files.len(),
                });
            }
            self.next = 0;
            self.pass_frames = 0;
        }
        let path = self.files[self.next].clone();
        self.next += 1;
        let mut frame = match self.how_to_read(&path)? {
            HowToRead::Headerless(fmt) => load_headerless(&path, &fmt)?,
            HowToRead::Options(opts) => load_input(&path, &opts)?.frame,
        };
        let interval = 1e9 / self.opts.fps;
        let ts = (self.sequence as f64 * interval).round() as u64;
        frame.meta.sequence = self.sequence;
        frame.meta.sensor_sequence = None;
        frame.meta.timestamp_ns = ts;
        frame.meta.source = Arc::from(path.display().to_string().as_str());
        self.sequence += 1;
        self.pass_frames += 1;
        if self.opts.pace {
            let clock = &self.opts.clock;
            let t0 = *self.anchor.get_or_insert_with(|| clock.now_ns());
            clock.sleep_until_ns(t0 + ts);
        }
        Ok(Some(frame))
    }

    fn kind(&self) -> SourceKind {
        SourceKind::Replay
    }

    fn describe(&self) -> String {
        match self.files.as_slice() {
            [one] => format!("file:{}", one.display()),
            [first, ..] => format!("files:{} (+{} more)", first.display(), self.files.len() - 1),
            [] => "files:(none)".into(),
        }
    }

    fn is_finished(&self) -> bool {
        self.finished
    }
}
