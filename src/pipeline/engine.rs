//! One camera's pipeline: capture thread → bounded queue → dispatcher → rayon pool → reorder
//! buffer → sinks, with every frame accounted for.
//!
//! ```text
//!  capture thread ──push──▶ FrameQueue ──pop──▶ dispatcher ──spawn──▶ compute pool (shared)
//!   (source.next_frame)     (drop-oldest live,   (index, size check,        │ result (any order)
//!                            backpressure replay)  max_in_flight permits)     ▼
//!                                                         orderer thread: reorder buffer, stamps
//!                                                         publish time + latency, stats ──▶ sink threads
//! ```
//!
//! * The dispatcher gives each frame it takes from the queue a dense `index`; a permit from a pool
//!   of `max_in_flight` tokens is held from dispatch until the frame leaves the reorder buffer, so at
//!   most `max_in_flight` frames are computing or waiting to be emitted.
//! * The orderer emits strictly in `index` order and hands an `Arc<FrameResult>` to every sink's
//!   thread (sinks own ports that are not `Send`, e.g. iceoryx2 publishers, so each is built inside
//!   its own thread by a [`SinkFactory`]).
//! * Pixel buffers go back to the frame pool once computed, gradient maps once every sink dropped
//!   the result.
//! * Shutdown: [`Pipeline::stop`] ends capture (it raises the [`Stop`] the source waits on, so a
//!   source pacing a recording stops waiting at once); everything already queued or in flight is
//!   still computed and emitted ("drained"); then the final stats go to the sinks, which finish (an
//!   MCAP writer writes its summary and index).
//! * When a drain takes too long, [`AbortHandle::abort`] cuts it short: the frames still queued,
//!   computing or waiting to be emitted are abandoned (logged with their number), the orderer
//!   stops waiting for them and never blocks on a full sink queue again, every sink skips the
//!   frames still in its queue (counted in `sink_frames_lost`), receives the final stats and
//!   finishes — so recordings get their summary, unless a sink is stuck inside one call.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{bounded, unbounded, Receiver, Sender};

use super::pool::BufferPool;
use super::queue::{FrameQueue, Push};
/// Re-exported from [`super::sinks`], where they live.
pub(crate) use super::sinks::{FrameResult, PooledMaps, SinkError, SinkEvent, SinkFactory};
use super::stage::{GradientMaps, Stage, StageError, StageOutput};
use super::stats::{RecorderState, Stats, StatsSnapshot};
use crate::capture::{Source, SourceKind};
use crate::clock::{monotonic_ns, Clock, Stop};
use crate::raw::{FrameMeta, RawFrame, RawPixels};

/// What a sink thread reports when it ends.
#[derive(Debug, Default)]
struct SinkOutcome {
    /// Errors that stopped a sink (or its start, or its finish).
    errors: Vec<String>,
    /// Errors a sink went on after ([`SinkError::Interrupted`]).
    interruptions: Vec<String>,
}

/// Parameters of one pipeline.
#[derive(Debug, Clone)]
pub struct PipelineSpec {
    /// Camera name.
    pub camera: String,
    /// Capture queue depth.
    pub queue_depth: usize,
    /// Frames computing or awaiting emission at once.
    pub max_in_flight: usize,
    /// The compute stage.
    pub stage: Stage,
    /// Hand every frame to the sinks too ([`FrameResult::frame`], for recording raw frames); its
    /// pixel buffer is then not recycled.
    pub keep_frames: bool,
}

/// What a finished pipeline reports.
#[derive(Debug, Clone)]
pub struct PipelineReport {
    /// Camera name.
    pub camera: String,
    /// Final counters.
    pub stats: StatsSnapshot,
    /// The source's last error: a frame it could not deliver (skipped, counted in
    /// `failed_source`) or, with [`Self::source_ended_on_error`], the error it ended on.
    pub source_error: Option<String>,
    /// The source ended on [`Self::source_error`] (truncated recording, lost device) rather than
    /// going on after it.
    pub source_ended_on_error: bool,
    /// Sink errors (each stopped its sink).
    pub sink_errors: Vec<String>,
    /// Errors a sink went on after ([`SinkError::Interrupted`]: the recorder paused by a full
    /// disk, then tried again).
    pub sink_interruptions: Vec<String>,
    /// Wall time from start to the end of the drain.
    pub elapsed: Duration,
    /// Wall time from start to the final stats message (the last frame handed to the sinks):
    /// the final stats' `fps` is `processed / active`, and so is the summary's throughput.
    pub active: Duration,
}

struct Item {
    frame: RawFrame,
    entered_ns: u64,
}

enum Event {
    Done(u64, Box<Computed>),
    DispatchFinished(u64),
    Stats,
    Reopen,
    Abort,
}

struct Computed {
    frame: Option<Arc<RawFrame>>,
    meta: FrameMeta,
    width: usize,
    height: usize,
    entered_ns: u64,
    result: Result<(StageOutput, GradientMaps), StageError>,
}

/// A running pipeline.
pub struct Pipeline {
    camera: String,
    stop: Stop,
    abort: Arc<AtomicBool>,
    stats: Arc<Stats>,
    events: Sender<Event>,
    /// The last source error and whether the source ended on it.
    source_error: Arc<Mutex<Option<(String, bool)>>>,
    threads: Vec<JoinHandle<()>>,
    orderer: Option<JoinHandle<(SinkOutcome, Duration)>>,
    queue: Arc<FrameQueue<Item>>,
    maps_pool: BufferPool<GradientMaps>,
    frame_pool: BufferPool<RawPixels>,
    started: Instant,
}

impl Pipeline {
    /// Start the threads. Sinks are built first (each in its own thread); if one fails to start,
    /// nothing else is started and the error is returned.
    pub fn start(
        spec: PipelineSpec,
        mut source: Box<dyn Source>,
        compute_pool: Arc<rayon::ThreadPool>,
        clock: Arc<dyn Clock>,
        sinks: Vec<SinkFactory>,
        frame_pool: BufferPool<RawPixels>,
    ) -> Result<Self, SinkError> {
        let camera: Arc<str> = Arc::from(spec.camera.as_str());
        let stats = Arc::new(Stats::default());
        let abort = Arc::new(AtomicBool::new(false));
        // Sink threads.
        let mut sink_txs = Vec::new();
        let mut sink_joins = Vec::new();
        for factory in sinks {
            let (sink_stats, sink_abort) = (stats.clone(), abort.clone());
            let (tx, rx) = bounded::<SinkEvent>(SINK_QUEUE);
            let (ready_tx, ready_rx) = bounded::<Result<(), SinkError>>(1);
            let join = std::thread::Builder::new()
                .name(format!("mosaicd-sink-{}", spec.camera))
                .spawn(move || sink_thread(factory, rx, ready_tx, &sink_stats, &sink_abort))
                .map_err(|e| SinkError::Start {
                    sink: "thread".into(),
                    message: e.to_string(),
                })?;
            match ready_rx.recv() {
                Ok(Ok(())) => {}
                Ok(Err(e)) => {
                    drop(tx);
                    let _ = join.join();
                    return Err(e);
                }
                Err(_) => {
                    return Err(SinkError::Start {
                        sink: "thread".into(),
                        message: "sink thread exited during start-up".into(),
                    })
                }
            }
            sink_txs.push(tx);
            sink_joins.push(join);
        }

        let stop = Stop::new();
        source.set_stop(stop.clone());
        let source_error = Arc::new(Mutex::new(None));
        let kind = source.kind();
        let queue = Arc::new(FrameQueue::<Item>::new(spec.queue_depth, kind));
        let maps_pool = BufferPool::<GradientMaps>::new(spec.max_in_flight + 2);
        let (ev_tx, ev_rx) = unbounded::<Event>();
        let (permit_tx, permit_rx) = bounded::<()>(spec.max_in_flight);
        for _ in 0..spec.max_in_flight {
            permit_tx.send(()).expect("capacity max_in_flight");
        }

        // The run's start: the summary's throughput and the final stats' fps count from here.
        let started = Instant::now();
        // Capture thread.
        let capture = {
            let (stop, stats, queue, err, fpool) = (
                stop.clone(),
                stats.clone(),
                queue.clone(),
                source_error.clone(),
                frame_pool.clone(),
            );
            std::thread::Builder::new()
                .name(format!("mosaicd-capture-{}", spec.camera))
                .spawn(move || {
                    capture_loop(&mut *source, kind, &stop, &stats, &queue, &err, &fpool);
                    queue.close();
                })
                .expect("spawn capture thread")
        };

        // Dispatcher thread.
        let dispatcher = {
            let keep = spec.keep_frames;
            let (queue, ev_tx, stage, pool, mpool, fpool) = (
                queue.clone(),
                ev_tx.clone(),
                Arc::new(spec.stage.clone()),
                compute_pool.clone(),
                maps_pool.clone(),
                frame_pool.clone(),
            );
            std::thread::Builder::new()
                .name(format!("mosaicd-dispatch-{}", spec.camera))
                .spawn(move || {
                    let mut index = 0u64;
                    let mut size: Option<(usize, usize)> = None;
                    while let Some(mut item) = queue.pop() {
                        if kind == SourceKind::Replay {
                            item.entered_ns = monotonic_ns();
                        }
                        if permit_rx.recv().is_err() {
                            break;
                        }
                        let expected = *size.get_or_insert((item.frame.width(), item.frame.height()));
                        let (ev_tx, mpool, fpool, stage) =
                            (ev_tx.clone(), mpool.clone(), fpool.clone(), stage.clone());
                        let i = index;
                        index += 1;
                        pool.spawn(move || {
                            let computed = compute_one(item, expected, &stage, &mpool, &fpool, keep);
                            let _ = ev_tx.send(Event::Done(i, Box::new(computed)));
                        });
                    }
                    let _ = ev_tx.send(Event::DispatchFinished(index));
                })
                .expect("spawn dispatcher thread")
        };

        // Orderer thread.
        let orderer = {
            let (stats, camera, mpool, abort) =
                (stats.clone(), camera.clone(), maps_pool.clone(), abort.clone());
            std::thread::Builder::new()
                .name(format!("mosaicd-order-{}", spec.camera))
                .spawn(move || {
                    let out = Outputs {
                        sinks: &sink_txs,
                        abort: &abort,
                        stats: &stats,
                    };
                    let active = order_loop(ev_rx, permit_tx, &*clock, camera, mpool, &out, started);
                    drop(sink_txs);
                    let mut all = SinkOutcome::default();
                    for j in sink_joins {
                        match j.join() {
                            Ok(o) => {
                                all.errors.extend(o.errors);
                                all.interruptions.extend(o.interruptions);
                            }
                            Err(_) => {
                                stats.failed_sink.fetch_add(1, Ordering::Relaxed);
                                all.errors.push("a sink thread panicked".into())
                            }
                        }
                    }
                    (all, active)
                })
                .expect("spawn orderer thread")
        };

        Ok(Self {
            camera: spec.camera,
            stop,
            abort,
            stats,
            events: ev_tx,
            source_error,
            threads: vec![capture, dispatcher],
            orderer: Some(orderer),
            queue,
            maps_pool,
            frame_pool,
            started,
        })
    }

    /// Stop capturing (a waiting source wakes at once); queued and in-flight frames are still
    /// processed.
    pub fn stop(&self) {
        self.stop.stop();
    }

    /// A handle that can cut this pipeline's drain short from another thread, once the pipeline
    /// itself was moved away to be joined.
    pub fn abort_handle(&self) -> AbortHandle {
        AbortHandle {
            stop: self.stop.clone(),
            abort: self.abort.clone(),
            events: self.events.clone(),
            queue: self.queue.clone(),
        }
    }

    /// Ask the orderer to send a stats snapshot to the sinks.
    pub fn publish_stats(&self) {
        let _ = self.events.send(Event::Stats);
    }

    /// Ask the sinks to start new output files before the next frame (SIGHUP).
    pub fn reopen(&self) {
        let _ = self.events.send(Event::Reopen);
    }

    /// Live counters.
    pub fn stats(&self) -> StatsSnapshot {
        self.stats.snapshot()
    }

    /// The shared counters themselves (latency histogram and recorder state too); they outlive
    /// the pipeline, so their final values can be read after [`Pipeline::join`].
    pub fn shared_stats(&self) -> Arc<Stats> {
        self.stats.clone()
    }

    /// The camera name.
    pub fn camera(&self) -> &str {
        &self.camera
    }

    /// True once every frame has been emitted and the sinks have finished.
    pub fn is_finished(&self) -> bool {
        self.orderer.as_ref().is_none_or(|j| j.is_finished())
    }

    /// Frames queued now.
    pub fn queued(&self) -> usize {
        self.queue.len()
    }

    /// Gradient-map and pixel-buffer allocations so far (steady state: constant).
    pub fn allocations(&self) -> (u64, u64) {
        (self.maps_pool.allocations(), self.frame_pool.allocations())
    }

    /// Wait for the drain to finish (call [`Pipeline::stop`] first for a live source).
    pub fn join(mut self) -> PipelineReport {
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        // A failed sink stops itself (the pipeline goes on); each counted itself in
        // `failed_sink` when it failed, so later stats messages carry it.
        let (sinks, active) = match self.orderer.take().map(|j| j.join()) {
            Some(Ok(o)) => o,
            _ => (
                SinkOutcome {
                    errors: vec!["the orderer thread panicked".into()],
                    interruptions: Vec::new(),
                },
                self.started.elapsed(),
            ),
        };
        let last = self
            .source_error
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone();
        PipelineReport {
            camera: self.camera.clone(),
            stats: self.stats.snapshot(),
            source_ended_on_error: last.as_ref().is_some_and(|(_, ended)| *ended),
            source_error: last.map(|(e, _)| e),
            sink_errors: sinks.errors,
            sink_interruptions: sinks.interruptions,
            elapsed: self.started.elapsed(),
            active,
        }
    }
}

/// Cuts a pipeline's drain short ([`Pipeline::abort_handle`]; see the module overview).
pub struct AbortHandle {
    stop: Stop,
    abort: Arc<AtomicBool>,
    events: Sender<Event>,
    queue: Arc<FrameQueue<Item>>,
}

impl AbortHandle {
    /// Abandon the frames not yet emitted and let the sinks finish with what they have. Stops
    /// capture too. Returns at once; [`Pipeline::join`] then returns as soon as the sinks are done.
    pub fn abort(&self) {
        self.stop.stop();
        self.abort.store(true, Ordering::Release);
        self.queue.close();
        let _ = self.events.send(Event::Abort);
    }
}

impl std::fmt::Debug for AbortHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AbortHandle")
            .field("aborted", &self.abort.load(Ordering::Relaxed))
            .finish_non_exhaustive()
    }
}

/// Events queued for one sink thread at most (the orderer waits when a sink is this far behind).
const SINK_QUEUE: usize = 256;
/// How often the orderer, waiting on a full sink queue, looks whether the drain was aborted.
const ABORT_POLL: Duration = Duration::from_millis(20);

/// Where the orderer's output goes, and the flag that tells it to stop waiting for slow sinks.
struct Outputs<'a> {
    sinks: &'a [Sender<SinkEvent>],
    abort: &'a AtomicBool,
    stats: &'a Stats,
}

impl Outputs<'_> {
    fn aborted(&self) -> bool {
        self.abort.load(Ordering::Acquire)
    }

    /// Hand `ev` to every sink, waiting while a sink's queue is full, unless the drain is
    /// aborted: then a full queue loses the event (a frame counted in `sink_frames_lost`).
    fn send_all(&self, ev: SinkEvent) {
        for s in self.sinks {
            let mut ev = ev.clone();
            loop {
                match s.send_timeout(ev, ABORT_POLL) {
                    Ok(()) | Err(crossbeam_channel::SendTimeoutError::Disconnected(_)) => break,
                    Err(crossbeam_channel::SendTimeoutError::Timeout(back)) => {
                        if self.aborted() {
                            if matches!(back, SinkEvent::Frame(_)) {
                                self.stats.sink_frames_lost.fetch_add(1, Ordering::Relaxed);
                            }
                            break;
                        }
                        ev = back;
                    }
                }
            }
        }
    }
}

/// Count the frames missing between the last sensor sequence number and `cur` as driver drops,
/// then remember `cur`. A sequence that goes backwards (a driver restart, a looped recording)
/// counts nothing.
fn sensor_gap(last: &mut Option<u64>, cur: Option<u64>, stats: &Stats) {
    let Some(cur) = cur else { return };
    if let Some(gap) = last.and_then(|prev| cur.checked_sub(prev)) {
        if gap > 1 {
            stats.dropped_driver.fetch_add(gap - 1, Ordering::Relaxed);
        }
    }
    *last = Some(cur);
}

/// Back-off after a source error on a live source (device hiccup) before asking again.
const SOURCE_ERROR_BACKOFF: Duration = Duration::from_millis(20);

fn capture_loop(
    source: &mut dyn Source,
    kind: SourceKind,
    stop: &Stop,
    stats: &Stats,
    queue: &FrameQueue<Item>,
    err: &Mutex<Option<(String, bool)>>,
    frame_pool: &BufferPool<RawPixels>,
) {
    let mut last_sensor_seq: Option<u64> = None;
    while !stop.is_stopped() {
        match source.next_frame() {
            Ok(Some(frame)) => {
                Stats::inc(&stats.captured);
                sensor_gap(&mut last_sensor_seq, frame.meta.sensor_sequence, stats);
                // Live: the driver's capture timestamp (same monotonic clock). Replay: stamped
                // again when the dispatcher takes the frame, so backpressure waiting inside the
                // reader is not counted as latency.
                let entered_ns = match kind {
                    SourceKind::Live => frame.meta.timestamp_ns.min(monotonic_ns()),
                    SourceKind::Replay => 0,
                };
                match queue.push(Item { frame, entered_ns }) {
                    Push::Queued => {}
                    Push::DroppedOldest(old) => {
                        Stats::inc(&stats.dropped_queue_full);
                        tracing::debug!(sequence = old.frame.meta.sequence, "dropped oldest queued frame");
                        frame_pool.give(old.frame.into_pixels());
                    }
                    Push::Closed(_) => break,
                }
            }
            Ok(None) => break,
            Err(e) => {
                Stats::inc(&stats.failed_source);
                // A frame the source could not deliver but whose sensor sequence it knows is
                // counted here as failed only, not also as a driver drop by the next frame.
                sensor_gap(&mut last_sensor_seq, e.sensor_sequence(), stats);
                tracing::warn!(source = %source.describe(), "source error: {e}");
                let ended = source.is_finished();
                *err.lock().unwrap_or_else(|e| e.into_inner()) = Some((e.to_string(), ended));
                if ended {
                    break;
                }
                if stop.wait_timeout(SOURCE_ERROR_BACKOFF) {
                    break;
                }
            }
        }
        if source.is_finished() {
            break;
        }
    }
}

fn compute_one(
    item: Item,
    expected: (usize, usize),
    stage: &Stage,
    mpool: &BufferPool<GradientMaps>,
    fpool: &BufferPool<RawPixels>,
    keep_frame: bool,
) -> Computed {
    let Item { frame, entered_ns } = item;
    let (width, height) = (frame.width(), frame.height());
    let result = if (width, height) != expected {
        Err(StageError::FrameSize {
            sequence: frame.meta.sequence,
            width,
            height,
            expected_width: expected.0,
            expected_height: expected.1,
        })
    } else {
        let mut maps = mpool.take(GradientMaps::default);
        match stage.compute(&frame, &mut maps) {
            Ok(out) => Ok((out, maps)),
            Err(e) => {
                mpool.give(maps);
                Err(e)
            }
        }
    };
    let meta = frame.meta.clone();
    let frame = if keep_frame {
        Some(Arc::new(frame))
    } else {
        fpool.give(frame.into_pixels());
        None
    };
    Computed {
        frame,
        meta,
        width,
        height,
        entered_ns,
        result,
    }
}

fn order_loop(
    events: Receiver<Event>,
    permits: Sender<()>,
    clock: &dyn Clock,
    camera: Arc<str>,
    mpool: BufferPool<GradientMaps>,
    out: &Outputs<'_>,
    started: Instant,
) -> Duration {
    let stats = out.stats;
    let mut pending: BTreeMap<u64, Box<Computed>> = BTreeMap::new();
    let mut next = 0u64;
    let mut total: Option<u64> = None;
    let send_all = |ev: SinkEvent| out.send_all(ev);
    // fps: over the last interval for periodic stats; over the whole run for the final stats
    // (so it agrees with the summary's throughput), never over the partial last interval.
    let mut last_tick = (started, 0u64);
    let stats_msg = |last_tick: &mut (Instant, u64), is_final: bool| {
        let snap = stats.snapshot();
        let now = Instant::now();
        let (since, base) = if is_final { (started, 0) } else { *last_tick };
        let dt = now.duration_since(since).as_secs_f64();
        let fps = if dt > 0.0 {
            (snap.processed - base) as f64 / dt
        } else {
            0.0
        };
        *last_tick = (now, snap.processed);
        (snap.to_msg(clock.now_ns(), fps as f32, is_final), now - started)
    };
    loop {
        if total == Some(next) {
            break;
        }
        if out.aborted() {
            let s = stats.snapshot();
            let accounted = s.processed + s.failed_compute + s.dropped_queue_full;
            tracing::warn!(
                camera = %camera,
                "shutdown timeout: {} frame(s) still queued or computing are abandoned; the sinks finish with what they have",
                s.captured.saturating_sub(accounted)
            );
            break;
        }
        let ev = match events.recv() {
            Ok(ev) => ev,
            Err(_) => break,
        };
        match ev {
            Event::Abort => continue,
            Event::Done(i, c) => {
                pending.insert(i, c);
            }
            Event::DispatchFinished(n) => total = Some(n),
            Event::Stats => {
                let (msg, _) = stats_msg(&mut last_tick, false);
                send_all(SinkEvent::Stats(msg));
            }
            Event::Reopen => send_all(SinkEvent::Reopen),
        }
        while let Some(c) = pending.remove(&next) {
            let index = next;
            next += 1;
            let _ = permits.send(());
            let c = *c;
            clock.observe(c.meta.timestamp_ns);
            match c.result {
                Ok((output, maps)) => {
                    let latency_ns = monotonic_ns().saturating_sub(c.entered_ns);
                    stats.record_latency_ns(latency_ns);
                    Stats::inc(&stats.processed);
                    stats
                        .detections
                        .fetch_add(output.detections.len() as u64, Ordering::Relaxed);
                    let over = output
                        .detections
                        .len()
                        .saturating_sub(crate::publish::messages::MAX_BOXES);
                    stats.box_overflow.fetch_add(over as u64, Ordering::Relaxed);
                    let result = Arc::new(FrameResult {
                        camera: camera.clone(),
                        index,
                        meta: c.meta,
                        width: c.width,
                        height: c.height,
                        output,
                        maps: PooledMaps {
                            maps: Some(maps),
                            pool: Some(mpool.clone()),
                        },
                        frame: c.frame,
                        publish_timestamp_ns: clock.now_ns(),
                        latency_ns,
                    });
                    send_all(SinkEvent::Frame(result));
                }
                Err(e) => {
                    Stats::inc(&stats.failed_compute);
                    tracing::warn!(camera = %camera, "frame failed: {e}");
                }
            }
        }
    }
    let (msg, active) = stats_msg(&mut last_tick, true);
    send_all(SinkEvent::Stats(msg));
    active
}

fn sink_thread(
    factory: SinkFactory,
    rx: Receiver<SinkEvent>,
    ready: Sender<Result<(), SinkError>>,
    stats: &Stats,
    abort: &AtomicBool,
) -> SinkOutcome {
    let mut sink = match factory() {
        Ok(s) => {
            let _ = ready.send(Ok(()));
            s
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return SinkOutcome::default();
        }
    };
    let mut out = SinkOutcome::default();
    let name = sink.name();
    // A recorder's state goes to the stats (the metrics textfile) after every event.
    let recorder = sink.recorder_state().is_some();
    let set_state = |s: Option<RecorderState>| {
        if let (true, Some(s)) = (recorder, s) {
            stats.set_recorder_state(s);
        }
    };
    set_state(sink.recorder_state());
    let mut failed = false;
    let mut panicked = false;
    // the sink's own count of frames it did not write, as far as it is in `sink_frames_lost`
    let mut lost = 0;
    let report_lost = |lost: &mut u64, now: u64| {
        if now > *lost {
            stats.sink_frames_lost.fetch_add(now - *lost, Ordering::Relaxed);
            *lost = now;
        }
    };
    for ev in rx {
        if abort.load(Ordering::Acquire) && matches!(ev, SinkEvent::Frame(_)) {
            // The drain was cut short: skip to the final stats and `finish`.
            stats.sink_frames_lost.fetch_add(1, Ordering::Relaxed);
            continue;
        }
        if failed {
            // keep draining so the pipeline never blocks on a dead sink
            if matches!(ev, SinkEvent::Frame(_)) {
                stats.sink_frames_lost.fetch_add(1, Ordering::Relaxed);
            }
            continue;
        }
        // A panic in a sink stops that sink like a write error, at once: it is logged and
        // counted now, and the frames after it are counted as lost, instead of the thread dying
        // and every later frame vanishing unseen. The sink is not asked anything after a panic
        // (not its count, not `finish`: a recorder cut mid-chunk is left without a summary
        // rather than closed over a half-written chunk).
        let r = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match &ev {
            SinkEvent::Frame(f) => sink.frame(f),
            SinkEvent::Stats(s) => sink.stats(s),
            SinkEvent::Reopen => sink.reopen(),
        })) {
            Ok(r) => r,
            Err(payload) => {
                let message = panic_message(payload.as_ref());
                tracing::error!("sink {name} panicked: {message}; this sink stops, the pipeline continues");
                stats.failed_sink.fetch_add(1, Ordering::Relaxed);
                out.errors.push(format!("sink {name} panicked: {message}"));
                if matches!(ev, SinkEvent::Frame(_)) {
                    stats.sink_frames_lost.fetch_add(1, Ordering::Relaxed);
                }
                failed = true;
                panicked = true;
                set_state(Some(RecorderState::Failed));
                continue;
            }
        };
        let mut now = sink.frames_not_written();
        if now == lost && matches!((&ev, &r), (SinkEvent::Frame(_), Err(SinkError::Write { .. }))) {
            // the frame that stopped a sink which does not count its own
            now += 1;
        }
        report_lost(&mut lost, now);
        set_state(sink.recorder_state());
        match r {
            Ok(()) => {}
            Err(e @ SinkError::Interrupted { .. }) => {
                tracing::error!("{e}");
                stats.failed_sink.fetch_add(1, Ordering::Relaxed);
                out.interruptions.push(e.to_string());
            }
            Err(e) => {
                tracing::error!("{e}; this sink stops, the pipeline continues");
                stats.failed_sink.fetch_add(1, Ordering::Relaxed);
                out.errors.push(e.to_string());
                failed = true;
                set_state(Some(RecorderState::Failed));
            }
        }
    }
    if panicked {
        // Leaked, not dropped: a recorder's `mcap::Writer` finishes its file on drop, which
        // would write a summary over the chunk the panic cut (and could panic again). What the
        // sink had buffered since its last flush is lost with it (for the recorder at most
        // `record.flush_frames` frames), and only the frame it panicked on is counted in
        // `sink_frames_lost`. A panic in `frames_not_written` or `finish` still ends the thread
        // (counted when the orderer joins it).
        std::mem::forget(sink);
        return out;
    }
    if !failed {
        let paused = sink.recorder_state() == Some(RecorderState::Paused);
        match sink.finish() {
            Err(e) => {
                stats.failed_sink.fetch_add(1, Ordering::Relaxed);
                out.errors.push(e.to_string());
                set_state(Some(RecorderState::Failed));
            }
            // A recording still paused at the end stays so: its last file was cut by the error.
            Ok(()) if !paused => set_state(Some(RecorderState::Finished)),
            Ok(()) => {}
        }
        report_lost(&mut lost, sink.frames_not_written());
    }
    out
}

/// The text of a panic's payload (`panic!("...")` gives a `&str` or a `String`).
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into())
}
