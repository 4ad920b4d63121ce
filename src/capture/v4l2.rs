//! [`V4l2Source`]: a live Bayer camera through V4L2 mmap streaming (`v4l` crate).
//!
//! Opening checks that the device exists and can stream video capture, enumerates its formats,
//! negotiates a Bayer format ([`negotiate`]: the preferred FourCC if offered, else the deepest bit
//! depth, unpacked before packed), sets size and frame rate, and maps `buffers` buffers. Each
//! dequeued buffer is unpacked by [`super::v4l2_formats`] into a [`RawFrame`] with
//! `sensor_sequence` = the driver's sequence, `timestamp_ns` = the buffer timestamp (the driver's
//! monotonic clock) and a dense `sequence`; gaps in the driver sequence are counted as driver drops
//! ([`SequenceTracker`]).
//!
//! When the device disappears (unplugged, driver reset), `next_frame` reports
//! [`CaptureError::DeviceLost`] once; later calls try to reopen it with exponential back-off
//! ([`Backoff`], on the injected [`Clock`]) and report [`CaptureError::DeviceUnavailable`] for each
//! failed attempt, so the daemon stays up, counts and reports, and resumes when the camera returns.
//! `SourceKind::Live`: the daemon drops the oldest frame under load.
//!
//! ```
//! use mosaicd::capture::{V4l2Options, V4l2Source};
//! let err = V4l2Source::open("/dev/video-does-not-exist", V4l2Options::default()).unwrap_err();
//! assert!(err.to_string().contains("/dev/video-does-not-exist"));
//! ```

use std::path::{Path, PathBuf};
use std::sync::Arc;

use v4l::buffer::Type as BufType;
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;

use super::v4l2_formats::{
    bayer_format, fourcc_str, raw_frame_from_v4l2, BayerFormat, Packing, V4l2FormatError,
};
use super::{CaptureError, Clock, MonotonicClock, Source, SourceKind};
use crate::raw::{FrameMeta, Levels, RawFrame};

/// Default number of mmap buffers.
pub(crate) const DEFAULT_BUFFERS: u32 = 4;
/// How long a dequeue may block before the device is considered gone (ms).
const DEQUEUE_TIMEOUT_MS: u64 = 2000;
/// Back-off defaults: first retry after 100 ms, doubling, at most 5 s.
const BACKOFF_INITIAL_NS: u64 = 100_000_000;
const BACKOFF_MAX_NS: u64 = 5_000_000_000;
const BACKOFF_FACTOR: u32 = 2;

/// Exponential back-off between reopen attempts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Backoff {
    /// First delay (ns).
    pub initial_ns: u64,
    /// Largest delay (ns).
    pub max_ns: u64,
    /// Growth factor per failed attempt.
    pub factor: u32,
    next_ns: u64,
    attempts: u32,
}

impl Default for Backoff {
    fn default() -> Self {
        Self::new(BACKOFF_INITIAL_NS, BACKOFF_MAX_NS, BACKOFF_FACTOR)
    }
}

impl Backoff {
    /// A back-off starting at `initial_ns`, multiplied by `factor` up to `max_ns`.
    pub fn new(initial_ns: u64, max_ns: u64, factor: u32) -> Self {
        Self {
            initial_ns,
            max_ns,
            factor: factor.max(1),
            next_ns: initial_ns,
            attempts: 0,
        }
    }

    /// The delay before the next attempt; grows for the one after.
    pub fn next_delay(&mut self) -> u64 {
        let d = self.next_ns.min(self.max_ns);
        self.next_ns = d.saturating_mul(self.factor as u64).min(self.max_ns);
        self.attempts += 1;
        d
    }

    /// Failed attempts since the last reset.
    pub fn attempts(&self) -> u32 {
        self.attempts
    }

    /// Back to the initial delay (after a success).
    pub fn reset(&mut self) {
        self.next_ns = self.initial_ns;
        self.attempts = 0;
    }
}

/// Counts frames the driver dropped from gaps in its sequence numbers.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct SequenceTracker {
    last: Option<u32>,
    /// Frames missing between consecutive driver sequence numbers, in total.
    pub drops: u64,
}

impl SequenceTracker {
    /// Observe a driver sequence number; returns how many frames were skipped before it.
    /// The 32-bit counter may wrap; a sequence that goes backwards (driver restart) is a new start.
    pub(crate) fn observe(&mut self, seq: u32) -> u64 {
        let gap = match self.last {
            Some(last) => {
                let d = seq.wrapping_sub(last);
                if d == 0 || d > u32::MAX / 2 {
                    0 // repeated or restarted
                } else {
                    (d - 1) as u64
                }
            }
            None => 0,
        };
        self.last = Some(seq);
        self.drops += gap;
        gap
    }

    /// Forget the last sequence (after a reopen the driver starts again).
    pub(crate) fn restart(&mut self) {
        self.last = None;
    }
}

/// Choose a Bayer format among the device's FourCCs: `preferred` if offered, else the deepest
/// bit depth, unpacked before packed (cheaper to read), in the device's order otherwise.
pub(crate) fn negotiate(
    offered: &[[u8; 4]],
    preferred: Option<[u8; 4]>,
) -> Result<BayerFormat, CaptureError> {
    let bayer: Vec<BayerFormat> = offered.iter().filter_map(|f| bayer_format(*f).ok()).collect();
    if let Some(p) = preferred {
        if let Some(f) = bayer.iter().find(|f| f.fourcc == p) {
            return Ok(*f);
        }
    }
    let rank = |f: &BayerFormat| {
        let unpacked = matches!(f.packing, Packing::U8 | Packing::U16Le);
        (f.bit_depth, unpacked)
    };
    let mut best: Option<BayerFormat> = None;
    for f in bayer {
        if best.as_ref().is_none_or(|b| rank(&f) > rank(b)) {
            best = Some(f);
        }
    }
    best.ok_or_else(|| CaptureError::NoBayerFormat {
        offered: offered
            .iter()
            .map(|f| fourcc_str(*f))
            .collect::<Vec<_>>()
            .join(" "),
        preferred: preferred.map(fourcc_str),
    })
}

/// Options of a V4L2 camera.
#[derive(Debug, Clone)]
pub struct V4l2Options {
    /// Requested width (`None`: keep the driver's).
    pub width: Option<u32>,
    /// Requested height (`None`: keep the driver's).
    pub height: Option<u32>,
    /// Preferred FourCC (e.g. `*b"pRAA"`); falls back to `negotiate`'s choice.
    pub fourcc: Option<[u8; 4]>,
    /// Requested frame rate.
    pub fps: Option<u32>,
    /// mmap buffers.
    pub buffers: u32,
    /// Black/white levels of the sensor (V4L2 does not say); default 0 / full scale.
    pub levels: Option<Levels>,
    /// Reopen back-off.
    pub backoff: Backoff,
    /// Clock for the back-off.
    pub clock: Arc<dyn Clock>,
}

impl Default for V4l2Options {
    fn default() -> Self {
        Self {
            width: None,
            height: None,
            fourcc: None,
            fps: None,
            buffers: DEFAULT_BUFFERS,
            levels: None,
            backoff: Backoff::default(),
            clock: Arc::new(MonotonicClock::new()),
        }
    }
}

/// The negotiated stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Negotiated {
    /// Format.
    pub format: BayerFormat,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Bytes per line.
    pub bytes_per_line: u32,
}

struct Open {
    // Field order: the stream (unmaps, stops) is dropped before the device (closes the fd).
    stream: v4l::io::mmap::Stream<'static>,
    _device: v4l::Device,
    neg: Negotiated,
}

/// A live V4L2 Bayer camera.
pub struct V4l2Source {
    path: PathBuf,
    opts: V4l2Options,
    open: Option<Open>,
    /// Negotiated format of the last successful open.
    neg: Negotiated,
    tracker: SequenceTracker,
    sequence: u64,
    source_name: Arc<str>,
    backoff: Backoff,
    next_attempt_ns: u64,
}

impl std::fmt::Debug for V4l2Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("V4l2Source")
            .field("path", &self.path)
            .field("negotiated", &self.neg)
            .field("connected", &self.open.is_some())
            .finish_non_exhaustive()
    }
}

fn io_err(path: &Path, what: &str) -> impl Fn(std::io::Error) -> CaptureError {
    let context = format!("{}: {what}", path.display());
    move |source| CaptureError::Io {
        context: context.clone(),
        source,
    }
}

fn open_device(path: &Path, opts: &V4l2Options) -> Result<Open, CaptureError> {
    if !path.exists() {
        return Err(CaptureError::DeviceMissing {
            path: path.to_path_buf(),
        });
    }
    let dev = v4l::Device::with_path(path).map_err(io_err(path, "cannot open V4L2 device"))?;
    let caps = dev
        .query_caps()
        .map_err(io_err(path, "not a V4L2 device (VIDIOC_QUERYCAP failed)"))?;
    use v4l::capability::Flags;
    if !caps.capabilities.contains(Flags::VIDEO_CAPTURE) || !caps.capabilities.contains(Flags::STREAMING) {
        return Err(CaptureError::NotCapture {
            path: path.to_path_buf(),
            card: caps.card,
        });
    }
    let offered: Vec<[u8; 4]> = dev
        .enum_formats()
        .map_err(io_err(path, "cannot enumerate formats"))?
        .iter()
        .map(|d| d.fourcc.repr)
        .collect();
    let format = negotiate(&offered, opts.fourcc)?;
    let mut fmt = dev.format().map_err(io_err(path, "cannot read the format"))?;
    fmt.fourcc = v4l::FourCC::new(&format.fourcc);
    if let Some(w) = opts.width {
        fmt.width = w;
    }
    if let Some(h) = opts.height {
        fmt.height = h;
    }
    let got = dev
        .set_format(&fmt)
        .map_err(io_err(path, "cannot set the format"))?;
    if got.fourcc.repr != format.fourcc {
        return Err(CaptureError::NoBayerFormat {
            offered: fourcc_str(got.fourcc.repr),
            preferred: Some(fourcc_str(format.fourcc)),
        });
    }
    if let Some(fps) = opts.fps {
        if let Err(e) = dev.set_params(&v4l::video::capture::Parameters::with_fps(fps)) {
            tracing::warn!(path = %path.display(), fps, error = %e, "cannot set the frame rate; using the driver's");
        }
    }
    let mut stream = v4l::io::mmap::Stream::with_buffers(&dev, BufType::VideoCapture, opts.buffers.max(1))
        .map_err(io_err(path, "cannot map capture buffers"))?;
    stream.set_timeout(std::time::Duration::from_millis(DEQUEUE_TIMEOUT_MS));
    // Some drivers leave bytesperline 0 (notably for packed formats): then rows are unpadded.
    let min_bpl = format.min_bytes_per_line(got.width as usize) as u32;
    let neg = Negotiated {
        format,
        width: got.width,
        height: got.height,
        bytes_per_line: if got.stride == 0 { min_bpl } else { got.stride },
    };
    tracing::info!(path = %path.display(), card = %caps.card, fourcc = %fourcc_str(format.fourcc),
        width = got.width, height = got.height, bytes_per_line = got.stride, "V4L2 camera open");
    Ok(Open {
        stream,
        _device: dev,
        neg,
    })
}

impl V4l2Source {
    /// Open and configure the camera at `path` (e.g. `/dev/video0`).
    pub fn open(path: impl AsRef<Path>, opts: V4l2Options) -> Result<Self, CaptureError> {
        let path = path.as_ref().to_path_buf();
        if opts.buffers == 0 {
            return Err(CaptureError::Option {
                name: "buffers",
                value: "0".into(),
                why: "at least 1",
            });
        }
        let open = open_device(&path, &opts)?;
        Ok(Self {
            source_name: Arc::from(path.display().to_string().as_str()),
            neg: open.neg,
            open: Some(open),
            backoff: opts.backoff,
            path,
            opts,
            tracker: SequenceTracker::default(),
            sequence: 0,
            next_attempt_ns: 0,
        })
    }

    /// The negotiated format and size.
    pub fn negotiated(&self) -> Negotiated {
        self.neg
    }

    /// Frames the driver dropped (gaps in its sequence numbers).
    pub fn driver_drops(&self) -> u64 {
        self.tracker.drops
    }

    /// True while the device is open.
    pub fn is_connected(&self) -> bool {
        self.open.is_some()
    }

    fn reopen(&mut self) -> Result<(), CaptureError> {
        let clock = self.opts.clock.clone();
        clock.sleep_until_ns(self.next_attempt_ns);
        match open_device(&self.path, &self.opts) {
            Ok(open) => {
                tracing::info!(path = %self.path.display(), attempts = self.backoff.attempts() + 1, "V4L2 camera reopened");
                self.neg = open.neg;
                self.open = Some(open);
                self.backoff.reset();
                self.tracker.restart();
                Ok(())
            }
            Err(e) => {
                let delay = self.backoff.next_delay();
                self.next_attempt_ns = clock.now_ns().saturating_add(delay);
                Err(CaptureError::DeviceUnavailable {
                    path: self.path.clone(),
                    attempt: self.backoff.attempts(),
                    retry_in_ms: delay / 1_000_000,
                    source: Box::new(e),
                })
            }
        }
    }
}

/// One dequeued buffer as a frame, or [`CaptureError::BadBuffer`] naming its driver sequence
/// number: a buffer the driver marked as failed (`V4L2_BUF_FLAG_ERROR`: its contents may be an
/// earlier frame's), or one whose contents do not hold the negotiated format (short, a value out
/// of range). An error of the setup rather than of this buffer (a stride or white level that does
/// not fit the negotiated format) stays [`CaptureError::Format`]: it fails every frame alike.
/// `bytesused` 0 means "not reported" on some drivers: then the whole buffer is the frame.
fn frame_from_buffer(
    neg: &Negotiated,
    levels: Option<Levels>,
    buf: &[u8],
    meta: &v4l::buffer::Metadata,
    path: &Path,
) -> Result<RawFrame, CaptureError> {
    let bad = |reason: String| CaptureError::BadBuffer {
        path: path.to_path_buf(),
        sequence: meta.sequence,
        reason,
    };
    if meta.flags.contains(v4l::buffer::Flags::ERROR) {
        return Err(bad("the driver marked it as failed (V4L2_BUF_FLAG_ERROR)".into()));
    }
    let used = match meta.bytesused as usize {
        0 => buf.len(),
        n => n.min(buf.len()),
    };
    raw_frame_from_v4l2(
        &neg.format,
        &buf[..used],
        neg.width as usize,
        neg.height as usize,
        neg.bytes_per_line as usize,
        levels,
    )
    .map_err(|e| match e {
        V4l2FormatError::BufferSize { .. } | V4l2FormatError::ValueOutOfRange { .. } => bad(e.to_string()),
        other => CaptureError::Format(other),
    })
}

impl Source for V4l2Source {
    fn next_frame(&mut self) -> Result<Option<RawFrame>, CaptureError> {
        if self.open.is_none() {
            self.reopen()?;
        }
        let open = self.open.as_mut().expect("opened above");
        let (buf, meta) = match CaptureStream::next(&mut open.stream) {
            Ok(x) => x,
            Err(source) => {
                self.open = None;
                self.backoff.reset();
                self.next_attempt_ns = self.opts.clock.now_ns();
                return Err(CaptureError::DeviceLost {
                    path: self.path.clone(),
                    source,
                });
            }
        };
        let result = frame_from_buffer(&open.neg, self.opts.levels, buf, meta, &self.path);
        // A buffer that is not a frame still used up its driver sequence number: observed
        // either way, so the next frame does not count it as a driver drop too.
        self.tracker.observe(meta.sequence);
        let mut frame = result?;
        // time_t is i32 on 32-bit ARM edge boxes: keep the widening cast.
        #[allow(clippy::unnecessary_cast)]
        let ts = meta.timestamp.sec as i64 * 1_000_000_000 + meta.timestamp.usec as i64 * 1000;
        frame.meta = FrameMeta {
            sequence: self.sequence,
            sensor_sequence: Some(meta.sequence as u64),
            timestamp_ns: ts.max(0) as u64,
            source: self.source_name.clone(),
        };
        self.sequence += 1;
        Ok(Some(frame))
    }

    fn kind(&self) -> SourceKind {
        SourceKind::Live
    }

    fn describe(&self) -> String {
        format!("v4l2:{}", self.path.display())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capture::FakeClock;

    #[test]
    fn negotiation_prefers_requested_then_deepest_unpacked() {
        let offered = [*b"YUYV", *b"pRAA", *b"RGGB", *b"RG10", *b"MJPG"];
        assert_eq!(negotiate(&offered, Some(*b"RGGB")).unwrap().fourcc, *b"RGGB");
        // Preference not offered: deepest, unpacked before packed.
        assert_eq!(negotiate(&offered, Some(*b"pRCC")).unwrap().fourcc, *b"RG10");
        assert_eq!(negotiate(&[*b"pgCC", *b"BA81"], None).unwrap().fourcc, *b"pgCC");
        let e = negotiate(&[*b"YUYV", *b"MJPG"], None).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("YUYV MJPG") && msg.contains("no Bayer"), "{msg}");
    }

    #[test]
    fn sequence_gaps_count_driver_drops_with_wrap_and_restart() {
        let mut t = SequenceTracker::default();
        assert_eq!(t.observe(10), 0);
        assert_eq!(t.observe(11), 0);
        assert_eq!(t.observe(14), 2);
        assert_eq!(t.observe(14), 0); // repeated
        assert_eq!(t.observe(3), 0); // backwards: driver restart, not a drop
        t.restart();
        assert_eq!(t.observe(500), 0);
        assert_eq!(t.drops, 2);
        let mut w = SequenceTracker::default();
        w.observe(u32::MAX - 1);
        assert_eq!(w.observe(1), 2); // wrapped: MAX and 0 missing
        assert_eq!(w.drops, 2);
    }

    /// What one dequeued buffer becomes, on real RG10 (16-bit little-endian) bytes: a frame, or
    /// an error that names the driver's sequence number (so the pipeline counts the lost frame
    /// once, as failed, not again as a driver drop).
    #[test]
    fn a_failed_short_or_out_of_range_buffer_is_an_error_naming_its_sequence() {
        let neg = Negotiated {
            format: bayer_format(*b"RG10").unwrap(),
            width: 4,
            height: 2,
            bytes_per_line: 8,
        };
        let good: Vec<u8> = (0..8u16).flat_map(|v| (v * 100).to_le_bytes()).collect();
        let meta = |bytesused: u32, flags: v4l::buffer::Flags| v4l::buffer::Metadata {
            bytesused,
            flags,
            sequence: 41,
            ..Default::default()
        };
        let path = Path::new("/dev/video0");
        let none = v4l::buffer::Flags::empty();
        let f = frame_from_buffer(&neg, None, &good, &meta(16, none), path).unwrap();
        assert_eq!((f.value(3, 1), f.bit_depth()), (700, 10));
        // bytesused 0 (not reported by some drivers): the whole buffer.
        assert!(frame_from_buffer(&neg, None, &good, &meta(0, none), path).is_ok());
        let sequence_of = |r: Result<RawFrame, CaptureError>| {
            let e = r.unwrap_err();
            assert!(matches!(e, CaptureError::BadBuffer { sequence: 41, .. }), "{e:?}");
            (e.sensor_sequence(), e.to_string())
        };
        // Marked failed by the driver: its contents may be an earlier frame's.
        let (seq, msg) = sequence_of(frame_from_buffer(
            &neg,
            None,
            &good,
            &meta(16, v4l::buffer::Flags::ERROR),
            path,
        ));
        assert_eq!(seq, Some(41));
        assert!(
            msg.contains("/dev/video0") && msg.contains("V4L2_BUF_FLAG_ERROR"),
            "{msg}"
        );
        // Short: the driver filled 12 of 16 bytes.
        let (_, msg) = sequence_of(frame_from_buffer(&neg, None, &good, &meta(12, none), path));
        assert!(msg.contains("sequence 41"), "{msg}");
        // A value above 10 bits.
        let mut hot = good.clone();
        hot[14..16].copy_from_slice(&1024u16.to_le_bytes());
        sequence_of(frame_from_buffer(&neg, None, &hot, &meta(16, none), path));
        // Not the buffer's fault: a white level above the negotiated depth fails every frame, and
        // stays a format error naming the levels.
        let levels = Some(Levels::uniform(0, 4095));
        let e = frame_from_buffer(&neg, levels, &good, &meta(16, none), path).unwrap_err();
        assert!(matches!(e, CaptureError::Format(_)), "{e:?}");
        assert_eq!(e.sensor_sequence(), None);
    }

    #[test]
    fn backoff_doubles_to_the_cap_and_resets() {
        let mut b = Backoff::new(100, 1000, 2);
        let d: Vec<u64> = (0..6).map(|_| b.next_delay()).collect();
        assert_eq!(d, vec![100, 200, 400, 800, 1000, 1000]);
        assert_eq!(b.attempts(), 6);
        b.reset();
        assert_eq!(b.next_delay(), 100);
    }

    /// A vanished device: every reopen attempt fails clearly, waits the back-off on the clock,
    /// and never panics.
    #[test]
    fn reopen_backs_off_on_the_injected_clock() {
        let clock = Arc::new(FakeClock::new(0));
        let opts = V4l2Options {
            backoff: Backoff::new(100, 400, 2),
            clock: clock.clone(),
            ..Default::default()
        };
        let mut src = V4l2Source {
            path: PathBuf::from("/dev/video-gone-for-test"),
            neg: Negotiated {
                format: bayer_format(*b"RGGB").unwrap(),
                width: 4,
                height: 4,
                bytes_per_line: 4,
            },
            backoff: opts.backoff,
            opts,
            open: None,
            tracker: SequenceTracker::default(),
            sequence: 0,
            source_name: Arc::from("x"),
            next_attempt_ns: 0,
        };
        let mut waits = Vec::new();
        for k in 1..=4u32 {
            let before = clock.now_ns();
            match src.next_frame() {
                Err(CaptureError::DeviceUnavailable { attempt, source, .. }) => {
                    assert_eq!(attempt, k);
                    assert!(matches!(*source, CaptureError::DeviceMissing { .. }));
                }
                other => panic!("unexpected {other:?}"),
            }
            waits.push(clock.now_ns() - before);
        }
        // First attempt immediately, then 100, 200, 400 (capped).
        assert_eq!(waits, vec![0, 100, 200, 400]);
        assert_eq!(src.kind(), SourceKind::Live);
    }
}
