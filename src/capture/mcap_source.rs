//! [`McapSource`]: replay the raw-frame channel of a mosaicd recording as a [`Source`].
//!
//! Frames come back exactly as recorded (pixels, pattern, bit depth, levels, gains, sensor
//! sequence, capture timestamp, source name), with `meta.sequence` renumbered densely from 0 for
//! this source. Options: as fast as possible or at the recorded rate (times a speed factor, on an
//! injected [`Clock`]; "Pacing" below), looped (timestamps keep increasing across loops: each pass is shifted by
//! the recording's span plus one frame interval), and starting `start_offset_ns` after the first
//! frame. `SourceKind::Replay`: the daemon back-pressures it and never drops.
//!
//! Pacing: each frame waits until its recorded time (relative to the first paced frame, divided
//! by the speed) on the clock. The wait is interruptible: it ends at once when the pipeline's
//! [`Stop`] is raised ([`Source::set_stop`]), and the frame is then delivered without waiting. A
//! step between two consecutive timestamps whose wait would exceed [`MAX_PACED_GAP_NS`] (10 s of
//! wall time), or a step backwards, is not slept through: it is logged as a warning, counted
//! ([`McapSource::pacing_jumps`]), and pacing restarts from that frame (it is delivered at once and
//! the next ones follow it at the recorded rate). So a recording whose timestamps jump by
//! centuries (`[0, u64::MAX, 5]`) replays, and stops, promptly.
//!
//! Damage handling: the file is streamed with every CRC checked (chunks before their messages are
//! used, the data section, the summary: at open) and record lengths limited to
//! [`crate::wire::record_length_limit`], which the frame-size limit
//! ([`crate::raw::limits`]) sets (the summary's records also to the file size): a chunk claiming
//! more is refused before it is decompressed, and a frame message larger than the limit
//! ([`RawError::TooLarge`]) before its pixels are copied. Each record is also bounded by the
//! file: the `mcap` reader zero-fills a buffer of the length a record header declares before it
//! reads the record, so a guard under it (`capture/mcap_guard.rs`) stops the stream before the
//! header of any record that would run past the end of the file (a file of a few bytes claiming a
//! 150 MB record had cost 158 MB: docs/fuzzing.md, finding 5).
//! * A **truncated** file (a recording cut by a crash or a full disk, or a writer killed in the
//!   middle of a chunk) yields every message of its complete chunks, then
//!   [`CaptureError::Truncated`] (the cut record named by a [`crate::capture::RecordPastEnd`] when
//!   its header is whole).
//! * A **corrupt** file is refused: a bad magic, footer or summary fails [`McapSource::open`]; damage
//!   inside the data yields [`CaptureError::Corrupt`] when reached and no frame from the damaged
//!   chunk. Nothing panics. Records that overrun an uncompressed chunk, which the `mcap` reader
//!   does not check (it would overflow), are stopped under it by a guard
//!   ([`crate::capture::ChunkOverrun`], `capture/mcap_guard.rs`).
//!
//! ```
//! use mosaicd::capture::{McapSource, McapSourceOptions, Source};
//! use mosaicd::raw::{Cfa, FrameMeta, Levels, RawFrame};
//! use mosaicd::record::{McapRecorder, RecorderOptions};
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("r.mcap");
//! let mut rec = McapRecorder::create(&path, RecorderOptions::default()).unwrap();
//! for i in 0..3u64 {
//!     let f = RawFrame::from_u8(4, 4, vec![i as u8; 16], Cfa::Rggb, Levels::uniform(0, 255)).unwrap()
//!         .with_meta(FrameMeta { sequence: i, timestamp_ns: 1000 * i, ..Default::default() });
//!     rec.write_frame(&f).unwrap();
//! }
//! rec.finish().unwrap();
//! let mut src = McapSource::open(&path, McapSourceOptions::default()).unwrap();
//! let mut n = 0;
//! while let Some(f) = src.next_frame().unwrap() {
//!     assert_eq!(f.value(0, 0) as u64, n);
//!     n += 1;
//! }
//! assert_eq!(n, 3);
//! ```

use std::fs::File;
use std::io::{BufReader, Cursor, Read, Seek};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::mcap_guard::{ChunkOverrun, RecordGuard};
use super::{CaptureError, Clock, Damage, MonotonicClock, Source, SourceKind, Stop};
use crate::raw::{FrameLimits, RawError, RawFrame};
use crate::wire::read::{read_summary, strict_reader_options};
use crate::wire::schema::{decode_raw_frame, decode_raw_frame_header, RAW_FRAME_SCHEMA};

/// Frame interval assumed when looping a one-frame recording (30 fps), ns.
const SINGLE_FRAME_LOOP_INTERVAL_NS: u64 = 33_333_333;
/// The longest wait between two consecutive paced frames (wall time, after the speed factor): a
/// longer step in the recorded timestamps is a jump, logged and counted, not slept through.
pub(crate) const MAX_PACED_GAP_NS: u64 = 10_000_000_000;
/// Read buffer in front of the file (bytes).
const READ_BUFFER: usize = 1 << 20;

/// How fast to replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pacing {
    /// No waiting: as fast as the consumer takes frames.
    AsFastAsPossible,
    /// At the recorded rate multiplied by `speed` (2.0 = twice as fast).
    Recorded {
        /// Speed factor (> 0).
        speed: f64,
    },
}

/// Replay options.
#[derive(Debug, Clone)]
pub struct McapSourceOptions {
    /// The raw-frame topic; `None` = the first channel with schema `mosaicd.RawFrame`.
    pub topic: Option<String>,
    /// Pacing.
    pub pacing: Pacing,
    /// Start again at the end.
    pub looped: bool,
    /// Skip frames earlier than the first frame's timestamp plus this (ns).
    pub start_offset_ns: u64,
    /// The clock used for pacing.
    pub clock: Arc<dyn Clock>,
}

impl Default for McapSourceOptions {
    fn default() -> Self {
        Self {
            topic: None,
            pacing: Pacing::AsFastAsPossible,
            looped: false,
            start_offset_ns: 0,
            clock: Arc::new(MonotonicClock),
        }
    }
}

type Reader = mcap::io::MessageReader<RecordGuard<Box<dyn Read + Send>>>;

/// Where a replay reads its recording from: the file at its path (opened again for each loop),
/// or bytes in memory ([`McapSource::from_bytes`]).
enum Recording {
    File,
    Memory(Arc<[u8]>),
}

/// Replays the raw frames of a recording.
pub struct McapSource {
    path: PathBuf,
    recording: Recording,
    opts: McapSourceOptions,
    reader: Reader,
    /// The topic locked onto (given, from the summary, or from the first raw message).
    topic: Option<String>,
    finished: bool,
    /// Frames delivered in total.
    delivered: u64,
    /// Raw frames read and skipped because they lie before `start_offset_ns`.
    skipped: u64,
    /// First frame timestamp of the recording (for the start offset).
    first_ts: Option<u64>,
    /// First / last recorded timestamp of the current pass, and the last interval seen.
    pass_first: Option<u64>,
    pass_last: u64,
    last_interval: u64,
    pass_frames: u64,
    /// Added to recorded timestamps (grows each loop).
    loop_offset: u64,
    /// Pacing anchor: (clock time, output timestamp) of the first paced frame (or of the frame
    /// after the last jump).
    anchor: Option<(u64, u64)>,
    /// Output timestamp of the previous paced frame.
    prev_paced: Option<u64>,
    /// Timestamp jumps not slept through (see the module overview).
    pacing_jumps: u64,
    /// The pipeline's stop flag: pacing waits end when it is raised.
    stop: Stop,
}

impl std::fmt::Debug for McapSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapSource")
            .field("path", &self.path)
            .field("topic", &self.topic)
            .field("delivered", &self.delivered)
            .finish_non_exhaustive()
    }
}

fn open_error(path: &Path) -> impl Fn(std::io::Error) -> CaptureError {
    let context = format!("cannot open recording {}", path.display());
    move |source| CaptureError::Io {
        context: context.clone(),
        source,
    }
}

/// Options that no recording can make valid.
fn check_options(opts: &McapSourceOptions) -> Result<(), CaptureError> {
    if let Pacing::Recorded { speed } = opts.pacing {
        if !(speed > 0.0 && speed.is_finite()) {
            return Err(CaptureError::Option {
                name: "pacing.speed",
                value: speed.to_string(),
                why: "a finite number > 0",
            });
        }
    }
    Ok(())
}

/// The streaming reader over the whole recording, from its start, behind the guard that bounds
/// every record by the file's length (known here: `stat` for a file).
fn open_reader(path: &Path, recording: &Recording) -> Result<Reader, CaptureError> {
    let (inner, len): (Box<dyn Read + Send>, u64) = match recording {
        Recording::File => {
            let file = File::open(path).map_err(open_error(path))?;
            let len = file.metadata().map_err(open_error(path))?.len();
            (Box::new(BufReader::with_capacity(READ_BUFFER, file)), len)
        }
        Recording::Memory(bytes) => (Box::new(Cursor::new(Arc::clone(bytes))), bytes.len() as u64),
    };
    Ok(mcap::io::MessageReader::new_with_options(
        RecordGuard::new(inner, len),
        strict_reader_options(),
    ))
}

impl McapSource {
    /// Open a recording. Fails on a missing file, a file that is not MCAP, a damaged footer or
    /// summary, or (when the summary is present) a missing raw-frame channel. A file without a
    /// summary (truncated, unfinished) opens and is read up to the damage.
    pub fn open(path: impl AsRef<Path>, opts: McapSourceOptions) -> Result<Self, CaptureError> {
        let path = path.as_ref().to_path_buf();
        check_options(&opts)?;
        let mut file = File::open(&path).map_err(open_error(&path))?;
        let len = file.metadata().map_err(open_error(&path))?.len();
        Self::open_from(&mut file, len, path, Recording::File, opts)
    }

    /// [`McapSource::open`] for a recording already in memory: the same checks, errors and
    /// frames; `origin` stands for the file's path in errors, warnings and
    /// [`Source::describe`]. A looped replay starts again from the same bytes.
    pub fn from_bytes(
        bytes: impl Into<Arc<[u8]>>,
        origin: impl AsRef<Path>,
        opts: McapSourceOptions,
    ) -> Result<Self, CaptureError> {
        let bytes: Arc<[u8]> = bytes.into();
        check_options(&opts)?;
        let len = bytes.len() as u64;
        let mut cursor = Cursor::new(Arc::clone(&bytes));
        let origin = origin.as_ref().to_path_buf();
        Self::open_from(&mut cursor, len, origin, Recording::Memory(bytes), opts)
    }

    /// The checks of [`McapSource::open`] on `r` (holding `len` bytes: the magic, then the footer
    /// and summary of a finished file), then the reader over the frames.
    fn open_from<R: Read + Seek>(
        r: &mut R,
        len: u64,
        path: PathBuf,
        recording: Recording,
        opts: McapSourceOptions,
    ) -> Result<Self, CaptureError> {
        let corrupt = |e: mcap::McapError| CaptureError::Corrupt {
            path: path.clone(),
            frames: 0,
            source: Damage::Mcap(e),
        };
        let io = open_error(&path);
        let mut magic = [0u8; 8];
        let head = r.read(&mut magic).map_err(&io)?;
        if head < magic.len() || magic != mcap::MAGIC {
            return Err(corrupt(mcap::McapError::BadMagic));
        }
        // A finished file ends with the magic: then its footer and summary must be sound.
        let mut topic = opts.topic.clone();
        let mut tail = [0u8; 8];
        let finished_file = len >= 16 && {
            use std::io::SeekFrom;
            r.seek(SeekFrom::End(-8)).map_err(&io)?;
            r.read_exact(&mut tail).map_err(&io)?;
            tail == mcap::MAGIC
        };
        if finished_file {
            if let Some(summary) = read_summary(r).map_err(corrupt)? {
                let raw: Vec<&str> = summary
                    .channels
                    .values()
                    .filter(|c| c.schema.as_ref().is_some_and(|s| s.name == RAW_FRAME_SCHEMA))
                    .map(|c| c.topic.as_str())
                    .collect();
                let ok = match &topic {
                    Some(t) => raw.contains(&t.as_str()),
                    None => !raw.is_empty(),
                };
                if !ok && !summary.channels.is_empty() {
                    let mut found: Vec<&str> = summary.channels.values().map(|c| c.topic.as_str()).collect();
                    found.sort();
                    return Err(CaptureError::NoRawChannel {
                        path,
                        wanted: topic.unwrap_or_else(|| format!("(schema {RAW_FRAME_SCHEMA})")),
                        found: found.join(", "),
                    });
                }
                if topic.is_none() {
                    let mut raw = raw;
                    raw.sort();
                    topic = raw.first().map(|s| s.to_string());
                }
            }
        } else {
            tracing::warn!(path = %path.display(), "recording has no footer (truncated or unfinished); reading what is complete");
        }
        let reader = open_reader(&path, &recording)?;
        Ok(Self {
            path,
            recording,
            opts,
            reader,
            topic,
            finished: false,
            delivered: 0,
            skipped: 0,
            first_ts: None,
            pass_first: None,
            pass_last: 0,
            last_interval: 0,
            pass_frames: 0,
            loop_offset: 0,
            anchor: None,
            prev_paced: None,
            pacing_jumps: 0,
            stop: Stop::new(),
        })
    }

    /// The raw-frame topic being replayed (known after open when the file has a summary).
    pub fn topic(&self) -> Option<&str> {
        self.topic.as_deref()
    }

    /// Frames delivered so far.
    pub fn frames_delivered(&self) -> u64 {
        self.delivered
    }

    fn classify(&self, e: mcap::McapError) -> CaptureError {
        // A record that overruns its uncompressed chunk, stopped by the guard under the reader.
        if let mcap::McapError::Io(io) = &e {
            if let Some(overrun) = io.get_ref().and_then(|e| e.downcast_ref::<ChunkOverrun>()) {
                return CaptureError::Corrupt {
                    path: self.path.clone(),
                    frames: self.delivered,
                    source: Damage::ChunkOverrun(overrun.clone()),
                };
            }
        }
        // UnexpectedEoc: the last chunk's header was never completed (the writer was killed
        // mid-chunk; its placeholder header has no CRC): also an interrupted recording. So is a
        // record that runs past the end of the file, stopped by the guard (`RecordPastEnd`, an
        // I/O error of kind UnexpectedEof).
        let truncated = match &e {
            mcap::McapError::UnexpectedEof | mcap::McapError::UnexpectedEoc => true,
            mcap::McapError::Io(io) => io.kind() == std::io::ErrorKind::UnexpectedEof,
            _ => false,
        };
        if truncated {
            CaptureError::Truncated {
                path: self.path.clone(),
                frames: self.delivered,
                source: e,
            }
        } else {
            CaptureError::Corrupt {
                path: self.path.clone(),
                frames: self.delivered,
                source: Damage::Mcap(e),
            }
        }
    }

    fn wants(&mut self, m: &mcap::Message<'_>) -> bool {
        match &self.topic {
            Some(t) => &m.channel.topic == t,
            None => {
                let raw = m
                    .channel
                    .schema
                    .as_ref()
                    .is_some_and(|s| s.name == RAW_FRAME_SCHEMA);
                if raw {
                    self.topic = Some(m.channel.topic.clone());
                }
                raw
            }
        }
    }

    /// Timestamp jumps that pacing did not sleep through (steps longer than
    /// `MAX_PACED_GAP_NS` of wall time, or backwards) so far.
    pub fn pacing_jumps(&self) -> u64 {
        self.pacing_jumps
    }

    /// Wait for the frame stamped `ts` (see "Pacing" in the module overview).
    fn pace(&mut self, ts: u64) {
        let Pacing::Recorded { speed } = self.opts.pacing else {
            return;
        };
        let clock = &self.opts.clock;
        // `as` saturates a float that exceeds u64 (a huge step at a slow speed).
        let wall = |dt: u64| (dt as f64 / speed) as u64;
        if let Some(prev) = self.prev_paced.replace(ts) {
            let step = ts.checked_sub(prev).map(wall);
            if step.is_none_or(|w| w > MAX_PACED_GAP_NS) {
                self.pacing_jumps += 1;
                tracing::warn!(
                    path = %self.path.display(),
                    from_ns = prev,
                    to_ns = ts,
                    jumps = self.pacing_jumps,
                    "recording timestamps jump (backwards, or more than {} s of replay time): not waited for; pacing restarts at this frame",
                    MAX_PACED_GAP_NS / 1_000_000_000
                );
                self.anchor = None;
            }
        }
        match self.anchor {
            None => self.anchor = Some((clock.now_ns(), ts)),
            Some((wall0, ts0)) => {
                // An interrupted wait (the pipeline stops) delivers the frame at once; the
                // capture loop sees the stop before asking for another.
                clock.wait_until_ns(wall0.saturating_add(wall(ts.saturating_sub(ts0))), &self.stop);
            }
        }
    }
}

impl Source for McapSource {
    fn next_frame(&mut self) -> Result<Option<RawFrame>, CaptureError> {
        if self.finished {
            return Ok(None);
        }
        loop {
            // mcap 0.26 panics on some malformed records (an Attachment whose body is shorter than
            // its header): caught here, the reader is not used again.
            // Quietly: the panic hook would print it (and a fuzzer's would abort).
            let reader = &mut self.reader;
            let next = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                crate::quiet_panic::call_quietly("/mcap-", || reader.next())
            }));
            let next = match next {
                Ok(n) => n,
                Err(panic) => {
                    self.finished = true;
                    let message = panic
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    return Err(CaptureError::Corrupt {
                        path: self.path.clone(),
                        frames: self.delivered,
                        source: Damage::ReaderPanic { message },
                    });
                }
            };
            let m = match next {
                Some(Ok(m)) => m,
                Some(Err(e)) => {
                    self.finished = true;
                    return Err(self.classify(e));
                }
                None => {
                    if self.opts.looped && self.pass_frames > 0 {
                        let first = self.pass_first.unwrap_or(0);
                        let interval = if self.last_interval > 0 {
                            self.last_interval
                        } else {
                            SINGLE_FRAME_LOOP_INTERVAL_NS
                        };
                        // Saturating: a file whose timestamps go backwards must not wrap the
                        // offset (nor panic in a debug build).
                        self.loop_offset = self
                            .loop_offset
                            .saturating_add(self.pass_last.saturating_sub(first))
                            .saturating_add(interval);
                        self.pass_first = None;
                        self.pass_frames = 0;
                        match open_reader(&self.path, &self.recording) {
                            Ok(r) => self.reader = r,
                            Err(e) => {
                                // The file went away between passes: the replay ends here.
                                self.finished = true;
                                return Err(e);
                            }
                        }
                        continue;
                    }
                    self.finished = true;
                    if self.delivered == 0 && self.skipped > 0 {
                        return Err(CaptureError::Option {
                            name: "start_offset_ns",
                            value: format!(
                                "{} (all {} raw frames are before it)",
                                self.opts.start_offset_ns, self.skipped
                            ),
                            why: "an offset shorter than the recording",
                        });
                    }
                    if self.delivered == 0 {
                        return Err(CaptureError::NoRawChannel {
                            path: self.path.clone(),
                            wanted: self
                                .topic
                                .clone()
                                .unwrap_or_else(|| format!("(schema {RAW_FRAME_SCHEMA})")),
                            found: "no raw frames in the file".into(),
                        });
                    }
                    return Ok(None);
                }
            };
            if !self.wants(&m) {
                continue;
            }
            // The frame-size limit, from the message's header, before its pixels are copied.
            if let Ok((h, _)) = decode_raw_frame_header(&m.data) {
                if let Err(limit) = FrameLimits::process().check(h.width.into(), h.height.into()) {
                    self.finished = true;
                    return Err(CaptureError::Raw(RawError::TooLarge {
                        path: self.path.clone(),
                        limit,
                    }));
                }
            }
            let mut frame = match decode_raw_frame(&m.data) {
                Ok(f) => f,
                Err(e) => {
                    self.finished = true;
                    return Err(CaptureError::Corrupt {
                        path: self.path.clone(),
                        frames: self.delivered,
                        source: Damage::Message(e),
                    });
                }
            };
            let ts = m.log_time;
            let first = *self.first_ts.get_or_insert(ts);
            // Only a start offset skips frames: a frame stamped before the first one (a file
            // whose time goes backwards) is still a frame.
            if self.opts.start_offset_ns > 0 && ts < first.saturating_add(self.opts.start_offset_ns) {
                self.skipped += 1;
                continue;
            }
            match self.pass_first {
                None => self.pass_first = Some(ts),
                Some(_) => self.last_interval = ts.saturating_sub(self.pass_last),
            }
            self.pass_last = ts;
            self.pass_frames += 1;
            let out_ts = ts.saturating_add(self.loop_offset);
            frame.meta.timestamp_ns = out_ts;
            frame.meta.sequence = self.delivered;
            self.delivered += 1;
            self.pace(out_ts);
            return Ok(Some(frame));
        }
    }

    fn kind(&self) -> SourceKind {
        SourceKind::Replay
    }

    fn describe(&self) -> String {
        format!("mcap:{}", self.path.display())
    }

    fn is_finished(&self) -> bool {
        self.finished
    }

    fn set_stop(&mut self, stop: Stop) {
        self.stop = stop;
    }
}
