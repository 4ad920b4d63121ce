//! [`McapRecorder`]: the MCAP writer (see the [module overview](super)).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use serde::Serialize;

use super::preview::preview_from_raw;
use crate::detect::Detection;
use crate::features::sift::Keypoint;
use crate::raw::RawFrame;
use crate::wire::schema::{self, DetectionsMessage, FoxgloveTime, RawImageMessage};
use crate::wire::{RecordError, Topics};
use files::{numbered_files, numbered_path};

mod files;
mod options;

pub(crate) use files::wall_clock_metadata;
pub use files::WALL_CLOCK_METADATA;
pub(crate) use options::DEFAULT_FLUSH_FRAMES;
pub use options::{
    Compression, FlushPolicy, PreviewOptions, RecorderOptions, RecordingSummary, RotatePolicy,
    DEFAULT_COMPRESSION_LEVEL,
};

/// Write buffer in front of the file (bytes).
const FILE_BUFFER: usize = 1 << 20;

/// Where an MCAP recording goes: a file, or any seekable writer (tests inject failing ones).
pub trait RecordSink: Write + Seek + Send {}
impl<T: Write + Seek + Send> RecordSink for T {}

/// Counts bytes that reached the sink (for size rotation).
struct Counted {
    inner: Box<dyn RecordSink>,
    pos: u64,
    len: Arc<AtomicU64>,
}

impl Write for Counted {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.pos += n as u64;
        self.len.fetch_max(self.pos, Ordering::Relaxed);
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl Seek for Counted {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        self.pos = self.inner.seek(to)?;
        Ok(self.pos)
    }
}

#[derive(Debug, Clone, Copy)]
struct ChannelIds {
    raw: Option<u16>,
    preview: Option<u16>,
    annotations: Option<u16>,
    detections: Option<u16>,
    stats: Option<u16>,
    keypoints: Option<u16>,
    sift: Option<u16>,
}

struct Segment {
    writer: mcap::Writer<Counted>,
    ids: ChannelIds,
    path: PathBuf,
    first_log_ns: Option<u64>,
    /// Bytes that reached the sink.
    len: Arc<AtomicU64>,
    /// Bytes before the first message (magic, header, schemas and channels written so far).
    preamble: u64,
}

enum State {
    /// No segment open yet (next write opens one).
    Idle,
    /// Writing.
    Open(Box<Segment>),
    /// A write failed; everything is refused.
    Failed(String),
    /// `finish` was called.
    Finished,
}

/// Where segments come from.
enum Target {
    /// A path; with rotation, `stem-NNNN.ext`.
    Path(PathBuf),
    /// One caller-provided sink (no rotation).
    Sink(Option<Box<dyn RecordSink>>),
}

/// Writes mosaicd recordings (see the [module overview](super)).
pub struct McapRecorder {
    opts: RecorderOptions,
    topics: Topics,
    target: Target,
    state: State,
    segment_index: u32,
    files: Vec<PathBuf>,
    /// Per-channel message sequence (raw, preview, annotations, detections, stats, keypoints,
    /// sift).
    seq: [u32; 7],
    frames: u64,
    detections: u64,
    stats: u64,
    frames_since_flush: u32,
    last_flush_ns: Option<u64>,
    /// Capture time of the last frame written with `write_frame` (its detections follow it).
    last_frame_ns: Option<u64>,
    buf: Vec<u8>,
    /// The file a write error stopped, and its preamble length (for [`McapRecorder::resume`]).
    failed_file: Option<(PathBuf, u64)>,
}

impl std::fmt::Debug for McapRecorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapRecorder")
            .field("topics", &self.topics)
            .field("files", &self.files)
            .field("frames", &self.frames)
            .finish_non_exhaustive()
    }
}

impl McapRecorder {
    /// Record into `path` (with rotation: `stem-0001.mcap`, `stem-0002.mcap`, ... next to it).
    /// The first file is created at once, so a bad path fails here.
    pub fn create(path: impl AsRef<Path>, opts: RecorderOptions) -> Result<Self, RecordError> {
        opts.validate()?;
        let mut r = Self::new(opts, Target::Path(path.as_ref().to_path_buf()));
        r.open_segment()?;
        Ok(r)
    }

    /// Record into one caller-provided sink (no rotation: options with rotation are refused).
    pub fn from_writer(sink: Box<dyn RecordSink>, opts: RecorderOptions) -> Result<Self, RecordError> {
        opts.validate()?;
        if opts.rotate.enabled() {
            return Err(RecordError::Option {
                name: "rotate",
                value: format!("{:?}", opts.rotate),
                why: "rotation needs a file path (McapRecorder::create)",
            });
        }
        let mut r = Self::new(opts, Target::Sink(Some(sink)));
        r.open_segment()?;
        Ok(r)
    }

    fn new(opts: RecorderOptions, target: Target) -> Self {
        Self {
            topics: Topics::new(&opts.camera),
            opts,
            target,
            state: State::Idle,
            segment_index: 0,
            files: Vec::new(),
            seq: [0; 7],
            frames: 0,
            detections: 0,
            stats: 0,
            frames_since_flush: 0,
            last_flush_ns: None,
            last_frame_ns: None,
            buf: Vec::new(),
            failed_file: None,
        }
    }

    /// The topics this recorder writes.
    pub fn topics(&self) -> &Topics {
        &self.topics
    }

    /// Files written so far (the current one last).
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    /// True after a write error stopped the recorder.
    pub fn is_failed(&self) -> bool {
        matches!(self.state, State::Failed(_))
    }

    /// True when [`McapRecorder::resume`] can go on after a write error: the recorder writes
    /// to a path with `keep_existing`, so the next file gets a name no file has (resuming never
    /// truncates the file that failed, nor any other).
    pub fn can_resume(&self) -> bool {
        matches!(self.target, Target::Path(_)) && self.opts.keep_existing
    }

    /// After a write error, go on in a new file: the next write opens the next `stem-NNNN`
    /// file (pruning the ring as a rotation does) and everything after it is recorded as
    /// before. The failed file stays as it is, cut at the failure (readers that tolerate a
    /// truncated file, such as [`crate::capture::McapSource`], read its complete messages).
    /// Returns false, changing nothing, when the recorder has not failed or
    /// [cannot resume](McapRecorder::can_resume).
    pub fn resume(&mut self) -> bool {
        if !(self.is_failed() && self.can_resume()) {
            return false;
        }
        self.discard_empty_failed_file();
        self.state = State::Idle;
        // The frame being written when the error came is not in any file: its results start
        // the next frame themselves.
        self.last_frame_ns = None;
        true
    }

    /// Finish the open file now (summary and index: complete, ready to copy) and start the next
    /// numbered file at the next write, as a rotation would (the daemon's SIGHUP). Returns
    /// `Ok(false)`, changing nothing, when no file is open or the next file would not get a new
    /// name (a path with neither `keep_existing` nor rotation: it would truncate this one).
    pub fn start_new_file(&mut self) -> Result<bool, RecordError> {
        let new_name = self.opts.keep_existing || self.opts.rotate.enabled();
        if !(matches!(self.state, State::Open(_)) && matches!(self.target, Target::Path(_)) && new_name) {
            return Ok(false);
        }
        self.close_segment()?;
        self.last_frame_ns = None;
        Ok(true)
    }

    /// Remove the file a write error stopped if it holds no message (it is no longer than its
    /// preamble: the error came before any message reached the disk), so attempts on a disk
    /// that is still full leave no empty files behind. Called by [`McapRecorder::resume`], and
    /// by a caller giving up while paused. Returns the removed path.
    pub fn discard_empty_failed_file(&mut self) -> Option<PathBuf> {
        let (path, preamble) = self.failed_file.take()?;
        let len = std::fs::metadata(&path).ok()?.len();
        if len > preamble {
            return None;
        }
        match std::fs::remove_file(&path) {
            Ok(()) => {
                self.files.retain(|p| p != &path);
                tracing::debug!(file = %path.display(), "removed a recording that holds no message");
                Some(path)
            }
            Err(e) => {
                tracing::warn!(file = %path.display(), "cannot remove an empty recording: {e}");
                None
            }
        }
    }

    /// The next file's path: `base` itself, or `stem-NNNN.ext` when rotating or when `base`
    /// exists and must be kept. Advances the file number.
    fn next_segment_path(&mut self, base: &Path) -> Result<PathBuf, RecordError> {
        let keep = self.opts.keep_existing;
        // With keep_existing, every file after the first is numbered, even when the plain name
        // is free again (its file copied off and removed): a name is never used twice.
        if !(self.opts.rotate.enabled() || keep && (base.exists() || self.segment_index > 0)) {
            self.segment_index += 1;
            return Ok(base.to_path_buf());
        }
        if keep {
            // After the highest number there: at the first file (a restart), and again at every
            // later one (a resume, a rotation), which other writers may have gone past meanwhile.
            // A directory that cannot be listed is an error at the first file; later, the
            // numbering goes on from ours (`create_new` still refuses a name that is taken).
            match numbered_files(base) {
                Ok(files) => {
                    let highest = files.last().map_or(0, |(n, _)| *n);
                    self.segment_index = self.segment_index.max(highest);
                }
                Err(e) if self.segment_index > 0 => {
                    tracing::warn!("cannot list earlier recordings ({e}); numbering on from our own");
                }
                Err(e) => return Err(e),
            }
        }
        self.segment_index = self
            .segment_index
            .checked_add(1)
            .ok_or_else(|| RecordError::Option {
                name: "rotate",
                value: format!("{}", base.display()),
                why: "file numbers are used up",
            })?;
        Ok(numbered_path(base, self.segment_index))
    }

    /// Delete the lowest-numbered files of `base` beyond `max_files` (never the one just opened).
    /// Called on rotation only, so a restart (or a crash loop) never deletes anything by starting.
    fn prune(&self, base: &Path, current: &Path) {
        let Some(keep) = self.opts.max_files else {
            return;
        };
        let files = match numbered_files(base) {
            Ok(f) => f,
            Err(e) => {
                tracing::warn!("record.max_files: cannot list old recordings: {e}");
                return;
            }
        };
        let excess = files.len().saturating_sub(keep as usize);
        for (_, p) in files.iter().take(excess).filter(|(_, p)| p != current) {
            match std::fs::remove_file(p) {
                Ok(()) => tracing::info!(file = %p.display(), "recording rotated out (record.max_files)"),
                Err(e) => tracing::warn!(file = %p.display(), "cannot remove an old recording: {e}"),
            }
        }
    }

    /// Create the next file; with `keep_existing`, a name taken meanwhile (another process on
    /// the same path) moves on to the next number, a bounded number of times.
    fn create_next(&mut self, base: &Path) -> Result<(File, PathBuf), RecordError> {
        for _ in 0..64 {
            let path = self.next_segment_path(base)?;
            let file = if self.opts.keep_existing {
                File::options().write(true).create_new(true).open(&path)
            } else {
                File::create(&path)
            };
            match file {
                Ok(f) => return Ok((f, path)),
                Err(e) if self.opts.keep_existing && e.kind() == std::io::ErrorKind::AlreadyExists => {
                    tracing::warn!(file = %path.display(), "exists already (another writer?); taking the next number");
                }
                Err(source) => return Err(RecordError::Create { path, source }),
            }
        }
        Err(RecordError::Create {
            path: base.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::AlreadyExists, "64 file names in a row exist"),
        })
    }

    fn open_segment(&mut self) -> Result<(), RecordError> {
        let rotating = self.segment_index > 0;
        let (sink, path): (Box<dyn RecordSink>, PathBuf) = match &mut self.target {
            Target::Path(base) => {
                let base = base.clone();
                let (file, path) = self.create_next(&base)?;
                tracing::info!(file = %path.display(), "recording");
                if rotating {
                    self.prune(&base, &path);
                }
                (Box::new(BufWriter::with_capacity(FILE_BUFFER, file)), path)
            }
            Target::Sink(s) => match s.take() {
                Some(s) => {
                    self.segment_index += 1;
                    (s, PathBuf::from("<writer>"))
                }
                None => return Err(RecordError::Finished),
            },
        };
        let compression = match self.opts.compression {
            Compression::Zstd => Some(mcap::Compression::Zstd),
            Compression::Lz4 => Some(mcap::Compression::Lz4),
            Compression::None => None,
        };
        let len = Arc::new(AtomicU64::new(0));
        let counted = Counted {
            inner: sink,
            pos: 0,
            len: len.clone(),
        };
        // A file that fails before its first message holds nothing: resume removes it.
        let is_file = matches!(self.target, Target::Path(_));
        let failed_file = &mut self.failed_file;
        let mut fail = |path: &Path, source| {
            if is_file {
                *failed_file = Some((path.to_path_buf(), u64::MAX));
            }
            RecordError::Write {
                path: path.to_path_buf(),
                source: Box::new(source),
            }
        };
        let mut writer = mcap::WriteOptions::new()
            .compression(compression)
            .compression_level(self.opts.compression_level)
            // Single-threaded zstd: identical bytes run after run.
            .compression_threads(0)
            .chunk_size(Some(self.opts.chunk_size))
            .profile("")
            .library(concat!("mosaicd/", env!("CARGO_PKG_VERSION")))
            .create(counted)
            .map_err(|e| fail(&path, e))?;
        let ids = Self::add_channels(&mut writer, &self.topics, &self.opts).map_err(|e| fail(&path, e))?;
        if let Some(clock) = self.opts.wall_clock {
            writer
                .write_metadata(&wall_clock_metadata(&clock.read()))
                .map_err(|e| fail(&path, e))?;
        }
        self.files.push(path.clone());
        let preamble = len.load(Ordering::Relaxed);
        self.state = State::Open(Box::new(Segment {
            writer,
            ids,
            path,
            first_log_ns: None,
            len,
            preamble,
        }));
        Ok(())
    }

    fn add_channels(
        w: &mut mcap::Writer<Counted>,
        topics: &Topics,
        opts: &RecorderOptions,
    ) -> mcap::McapResult<ChannelIds> {
        let none = BTreeMap::new();
        let raw = if opts.raw {
            let s = w.add_schema(
                schema::RAW_FRAME_SCHEMA,
                schema::RAW_FRAME_SCHEMA_ENCODING,
                schema::RAW_FRAME_SCHEMA_TEXT.as_bytes(),
            )?;
            Some(w.add_channel(s, &topics.raw, schema::RAW_FRAME_ENCODING, &none)?)
        } else {
            None
        };
        let preview = match opts.preview {
            Some(p) => {
                let s = w.add_schema(
                    schema::RAW_IMAGE_SCHEMA,
                    "jsonschema",
                    schema::raw_image_json_schema().as_bytes(),
                )?;
                let mut meta = BTreeMap::new();
                meta.insert("decimation".to_string(), p.decimation.to_string());
                Some(w.add_channel(s, &topics.preview, "json", &meta)?)
            }
            None => None,
        };
        let annotations_schema = if opts.results || opts.keypoints {
            Some(w.add_schema(
                schema::IMAGE_ANNOTATIONS_SCHEMA,
                "jsonschema",
                schema::image_annotations_json_schema().as_bytes(),
            )?)
        } else {
            None
        };
        let (annotations, detections, stats) = match annotations_schema.filter(|_| opts.results) {
            Some(s) => {
                let annotations = w.add_channel(s, &topics.annotations, "json", &none)?;
                let s = w.add_schema(
                    schema::DETECTIONS_SCHEMA,
                    "jsonschema",
                    schema::DETECTIONS_JSON_SCHEMA.as_bytes(),
                )?;
                let detections = w.add_channel(s, &topics.detections, "json", &none)?;
                let s = w.add_schema(
                    schema::STATS_SCHEMA,
                    "jsonschema",
                    schema::STATS_JSON_SCHEMA.as_bytes(),
                )?;
                let stats = w.add_channel(s, &topics.stats, "json", &none)?;
                (Some(annotations), Some(detections), Some(stats))
            }
            None => (None, None, None),
        };
        // Added last, so the other channels keep their ids whether or not keypoints are recorded.
        let (keypoints, sift) = if let (true, Some(annotations_schema)) = (opts.keypoints, annotations_schema)
        {
            let k = w.add_channel(annotations_schema, &topics.keypoints, "json", &none)?;
            let s = w.add_schema(
                schema::SIFT_FEATURES_SCHEMA,
                "jsonschema",
                schema::SIFT_FEATURES_JSON_SCHEMA.as_bytes(),
            )?;
            (Some(k), Some(w.add_channel(s, &topics.sift, "json", &none)?))
        } else {
            (None, None)
        };
        Ok(ChannelIds {
            raw,
            preview,
            annotations,
            detections,
            stats,
            keypoints,
            sift,
        })
    }

    /// The open segment, opening one if needed; refuses after failure or finish.
    fn segment(&mut self) -> Result<&mut Segment, RecordError> {
        match &self.state {
            State::Failed(first) => {
                return Err(RecordError::Stopped { first: first.clone() });
            }
            State::Finished => return Err(RecordError::Finished),
            State::Idle => self.open_segment_or_fail()?,
            State::Open(_) => {}
        }
        match &mut self.state {
            State::Open(s) => Ok(s),
            _ => unreachable!("opened above"),
        }
    }

    fn open_segment_or_fail(&mut self) -> Result<(), RecordError> {
        self.open_segment().inspect_err(|e| {
            self.state = State::Failed(e.to_string());
        })
    }

    /// Mark failed, drop the writer (its summary attempt may fail too; ignored) and build the error.
    fn fail(&mut self, source: mcap::McapError) -> RecordError {
        let path = match &self.state {
            State::Open(s) => {
                if matches!(self.target, Target::Path(_)) {
                    self.failed_file = Some((s.path.clone(), s.preamble));
                }
                s.path.clone()
            }
            _ => PathBuf::from("<writer>"),
        };
        let err = RecordError::Write {
            path,
            source: Box::new(source),
        };
        self.state = State::Failed(err.to_string());
        err
    }

    fn write_message(
        &mut self,
        slot: usize,
        channel: u16,
        log_ns: u64,
        data: &[u8],
    ) -> Result<(), RecordError> {
        let sequence = self.seq[slot];
        let seg = self.segment()?;
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence,
            log_time: log_ns,
            publish_time: log_ns,
        };
        match seg.writer.write_to_known_channel(&header, data) {
            Ok(()) => {
                self.seq[slot] = sequence.wrapping_add(1);
                Ok(())
            }
            Err(e) => Err(self.fail(e)),
        }
    }

    /// Rotate before a frame at `log_ns` when the current file is over a limit.
    fn maybe_rotate(&mut self, log_ns: u64) -> Result<(), RecordError> {
        let rot = self.opts.rotate;
        if !rot.enabled() {
            return Ok(());
        }
        let State::Open(seg) = &mut self.state else {
            return Ok(());
        };
        let Some(first) = seg.first_log_ns else {
            return Ok(());
        };
        let over_bytes = rot.bytes.is_some_and(|b| seg.len.load(Ordering::Relaxed) >= b);
        let over_time = rot.duration_ns.is_some_and(|d| log_ns.saturating_sub(first) >= d);
        if over_bytes || over_time {
            self.close_segment()?;
            self.open_segment_or_fail()?;
        }
        Ok(())
    }

    /// Finish the open file: summary, index, footer, then flush the buffered sink so a late write
    /// error (disk full) is reported rather than lost in a drop.
    fn close_segment(&mut self) -> Result<(), RecordError> {
        let State::Open(mut seg) = std::mem::replace(&mut self.state, State::Idle) else {
            return Ok(());
        };
        let fail = |state: &mut State, path: PathBuf, source| {
            let err = RecordError::Write {
                path,
                source: Box::new(source),
            };
            *state = State::Failed(err.to_string());
            err
        };
        if let Err(e) = seg.writer.finish() {
            return Err(fail(&mut self.state, seg.path, e));
        }
        let mut sink = seg.writer.into_inner();
        if let Err(e) = sink.flush() {
            return Err(fail(&mut self.state, seg.path, e.into()));
        }
        Ok(())
    }

    /// Start the frame captured at `t`: open a file if none is, rotate before the frame when the
    /// file is over a limit, and note the file's first time. Called once per frame, by
    /// `write_frame` or, for results recorded without their frame, by `write_detections`.
    fn begin_frame(&mut self, t: u64) -> Result<(), RecordError> {
        self.segment()?;
        self.maybe_rotate(t)?;
        if let State::Open(seg) = &mut self.state {
            seg.first_log_ns.get_or_insert(t);
        }
        Ok(())
    }

    /// Record one frame: the lossless raw message and the preview. Log time = capture timestamp.
    pub fn write_frame(&mut self, frame: &RawFrame) -> Result<(), RecordError> {
        let t = frame.meta.timestamp_ns;
        self.begin_frame(t)?;
        let ids = self.segment()?.ids;
        if let Some(ch) = ids.raw {
            let mut buf = std::mem::take(&mut self.buf);
            schema::encode_raw_frame(frame, &mut buf);
            let r = self.write_message(0, ch, t, &buf);
            self.buf = buf;
            r?;
        }
        if let (Some(ch), Some(p)) = (ids.preview, self.opts.preview) {
            if let Some(pv) = preview_from_raw(frame, p.decimation as usize) {
                let msg = RawImageMessage {
                    timestamp: FoxgloveTime::from_ns(t),
                    frame_id: self.opts.camera.clone(),
                    width: pv.width as u32,
                    height: pv.height as u32,
                    encoding: frame.cfa().foxglove_encoding(false).to_string(),
                    step: pv.width as u32,
                    data: schema::base64_encode(&pv.data),
                };
                let json = serde_json::to_vec(&msg).expect("preview serialises");
                self.write_message(1, ch, t, &json)?;
            }
        }
        self.last_frame_ns = Some(t);
        self.frames += 1;
        self.frames_since_flush += 1;
        let last = *self.last_flush_ns.get_or_insert(t);
        let f = self.opts.flush;
        let due = f.every_frames.is_some_and(|n| self.frames_since_flush >= n)
            || f.every_ns.is_some_and(|d| t.saturating_sub(last) >= d);
        if due {
            self.flush()?;
            self.last_flush_ns = Some(t);
        }
        Ok(())
    }

    /// Record the detections of one frame: `mosaicd.Detections` (full-frame coordinates) and
    /// `foxglove.ImageAnnotations` (preview coordinates when a preview is recorded).
    pub fn write_detections(
        &mut self,
        sequence: u64,
        timestamp_ns: u64,
        frame_width: u32,
        frame_height: u32,
        detections: &[Detection],
    ) -> Result<(), RecordError> {
        if self.last_frame_ns != Some(timestamp_ns) {
            // Results recorded without their frame start the frame themselves.
            self.begin_frame(timestamp_ns)?;
        }
        let ids = self.segment()?.ids;
        let (Some(annotations), Some(detections_ch)) = (ids.annotations, ids.detections) else {
            return Err(no_results());
        };
        let scale = self.opts.preview.map(|p| p.decimation as f64).unwrap_or(1.0);
        let ann = schema::annotations_from_detections(timestamp_ns, detections, scale);
        let json = serde_json::to_vec(&ann).expect("annotations serialise");
        self.write_message(2, annotations, timestamp_ns, &json)?;
        let msg = DetectionsMessage {
            sequence,
            timestamp_ns,
            frame_width,
            frame_height,
            detections: detections.to_vec(),
        };
        let json = serde_json::to_vec(&msg).expect("detections serialise");
        self.write_message(3, detections_ch, timestamp_ns, &json)?;
        self.detections += 1;
        Ok(())
    }

    /// Record the mosaic SIFT keypoints of one frame as `foxglove.ImageAnnotations` points on
    /// `/<camera>/keypoints` (preview coordinates when a preview is recorded). Refused with
    /// [`RecordError::Option`] when the recorder was created without `keypoints`.
    pub fn write_keypoints(&mut self, timestamp_ns: u64, keypoints: &[Keypoint]) -> Result<(), RecordError> {
        let Some(ch) = self.segment()?.ids.keypoints else {
            return Err(RecordError::Option {
                name: "keypoints",
                value: "false".into(),
                why: "true to record keypoints",
            });
        };
        let scale = self.opts.preview.map(|p| p.decimation as f64).unwrap_or(1.0);
        let ann = schema::annotations_from_keypoints(timestamp_ns, keypoints, scale);
        let json = serde_json::to_vec(&ann).expect("annotations serialise");
        self.write_message(5, ch, timestamp_ns, &json)
    }

    /// Record the mosaic SIFT features of one frame as `mosaicd.SiftFeatures` on `/<camera>/sift`:
    /// keypoints in full-frame coordinates and, when given, their descriptors (`descriptors[i]`
    /// belongs to `keypoints[i]`; a length mismatch is refused). Refused with
    /// [`RecordError::Option`] when the recorder was created without `keypoints`.
    pub fn write_sift(
        &mut self,
        sequence: u64,
        timestamp_ns: u64,
        frame_width: u32,
        frame_height: u32,
        keypoints: &[Keypoint],
        descriptors: Option<&[[u8; crate::features::sift::DESCRIPTOR_LEN]]>,
    ) -> Result<(), RecordError> {
        let Some(ch) = self.segment()?.ids.sift else {
            return Err(RecordError::Option {
                name: "keypoints",
                value: "false".into(),
                why: "true to record SIFT features",
            });
        };
        if let Some(d) = descriptors.filter(|d| d.len() != keypoints.len()) {
            return Err(RecordError::Option {
                name: "descriptors",
                value: format!("{} for {} keypoints", d.len(), keypoints.len()),
                why: "one descriptor per keypoint",
            });
        }
        let msg = schema::SiftFeaturesMessage {
            sequence,
            timestamp_ns,
            frame_width,
            frame_height,
            keypoints: keypoints.to_vec(),
            descriptors: schema::descriptors_base64(descriptors.unwrap_or_default()),
        };
        let json = serde_json::to_vec(&msg).expect("SIFT features serialise");
        self.write_message(6, ch, timestamp_ns, &json)
    }

    /// Record a stats message (any serialisable value, e.g. `serde_json::Value` or a struct).
    pub fn write_stats<T: Serialize + ?Sized>(
        &mut self,
        timestamp_ns: u64,
        stats: &T,
    ) -> Result<(), RecordError> {
        let Some(stats_ch) = self.segment()?.ids.stats else {
            return Err(no_results());
        };
        let json = serde_json::to_vec(stats).map_err(|e| RecordError::Option {
            name: "stats",
            value: e.to_string(),
            why: "a value that serialises to JSON",
        })?;
        self.write_message(4, stats_ch, timestamp_ns, &json)?;
        self.stats += 1;
        Ok(())
    }

    /// Close the open chunk and push it to the file (what a crash can lose ends here).
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.frames_since_flush = 0;
        let r = match &mut self.state {
            State::Open(seg) => seg.writer.flush(),
            State::Failed(first) => return Err(RecordError::Stopped { first: first.clone() }),
            _ => return Ok(()),
        };
        r.map_err(|e| self.fail(e))
    }

    /// Write the summary and index and close the file. Idempotent on success.
    pub fn finish(&mut self) -> Result<RecordingSummary, RecordError> {
        match &self.state {
            State::Failed(first) => return Err(RecordError::Stopped { first: first.clone() }),
            State::Finished => return Ok(self.summary()),
            _ => {}
        }
        self.close_segment()?;
        self.state = State::Finished;
        Ok(self.summary())
    }

    fn summary(&self) -> RecordingSummary {
        RecordingSummary {
            files: self.files.clone(),
            frames: self.frames,
            detections: self.detections,
            stats: self.stats,
        }
    }
}

/// Writing results to a recorder created without result channels.
fn no_results() -> RecordError {
    RecordError::Option {
        name: "results",
        value: "false".into(),
        why: "true to record detections and stats",
    }
}
