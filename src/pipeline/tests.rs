//! Pipeline-level unit tests (ordering, determinism, drop policy, pooling, accounting).

use std::sync::Arc;

use super::engine::{Pipeline, PipelineSpec};
use super::sinks::{strip_wall_clock, CollectSink};
use super::stage::{Stage, StageSpec};
use crate::capture::synthetic::{SyntheticSource, SyntheticSpec};
use crate::clock::ReplayClock;
use crate::pool::BufferPool;

fn run(
    threads: usize,
    in_flight: usize,
    spec: SyntheticSpec,
) -> (super::engine::PipelineReport, Vec<serde_json::Value>) {
    run_with(threads, in_flight, spec, Vec::new())
}

/// [`run`] with `sinks` started before the collecting one.
fn run_with(
    threads: usize,
    in_flight: usize,
    spec: SyntheticSpec,
    sinks: Vec<super::engine::SinkFactory>,
) -> (super::engine::PipelineReport, Vec<serde_json::Value>) {
    let (report, records, _) = run_with_stats(threads, in_flight, spec, sinks);
    (report, records)
}

/// [`run_with`], also returning the pipeline's shared counters after it ended.
fn run_with_stats(
    threads: usize,
    in_flight: usize,
    spec: SyntheticSpec,
    mut sinks: Vec<super::engine::SinkFactory>,
) -> (
    super::engine::PipelineReport,
    Vec<serde_json::Value>,
    Arc<super::stats::Stats>,
) {
    let pool = Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap(),
    );
    let frames = BufferPool::new(16);
    let src = SyntheticSource::with_pool(spec, frames.clone());
    let sink = CollectSink::default();
    sinks.push(sink.factory("t"));
    let p = Pipeline::start(
        PipelineSpec {
            camera: "t".into(),
            queue_depth: 3,
            max_in_flight: in_flight,
            stage: Stage::new(
                StageSpec {
                    strip_rows: 8,
                    ..StageSpec::default()
                },
                None,
            )
            .unwrap(),
            keep_frames: false,
        },
        Box::new(src),
        pool,
        Arc::new(ReplayClock::default()),
        sinks,
        frames,
    )
    .unwrap();
    let stats = p.shared_stats();
    let report = p.join();
    (report, sink.take(), stats)
}

fn text(records: &[serde_json::Value]) -> String {
    strip_wall_clock(&records.iter().map(|r| format!("{r}\n")).collect::<String>())
}

#[test]
fn replay_output_is_identical_for_1_2_4_threads_and_in_order() {
    let spec = SyntheticSpec {
        width: 96,
        height: 64,
        frames: 24,
        ..Default::default()
    };
    let (r1, rec1) = run(1, 1, spec.clone());
    assert_eq!(r1.stats.processed, 24);
    let t1 = text(&rec1);
    for (threads, in_flight) in [(2, 2), (4, 4), (4, 8)] {
        let (r, rec) = run(threads, in_flight, spec.clone());
        assert_eq!(r.stats.processed, 24);
        assert_eq!(text(&rec), t1, "threads={threads} in_flight={in_flight}");
    }
    let idx: Vec<u64> = rec1.iter().filter_map(|r| r["index"].as_u64()).collect();
    assert_eq!(idx, (0..24).collect::<Vec<_>>());
    // the final stats line is last and complete
    let last = rec1.last().unwrap();
    assert_eq!(last["type"], "final_stats");
    assert_eq!(last["processed"], 24);
}

#[test]
fn wrong_size_frame_is_counted_and_nothing_else_is_lost() {
    let spec = SyntheticSpec {
        width: 32,
        height: 16,
        frames: 10,
        wrong_size_at: Some(4),
        ..Default::default()
    };
    let (r, rec) = run(2, 3, spec);
    assert_eq!(r.stats.captured, 10);
    assert_eq!(r.stats.processed, 9);
    assert_eq!(r.stats.failed_compute, 1);
    let seqs: Vec<u64> = rec.iter().filter_map(|r| r["sequence"].as_u64()).collect();
    assert_eq!(seqs, vec![0, 1, 2, 3, 5, 6, 7, 8, 9]);
}

#[test]
fn no_per_frame_allocation_growth_after_warm_up() {
    let pool = Arc::new(rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap());
    let frames = BufferPool::new(16);
    let run_frames = |n: u64, frames: &BufferPool<_>| {
        let src = SyntheticSource::with_pool(
            SyntheticSpec {
                width: 64,
                height: 32,
                frames: n,
                ..Default::default()
            },
            frames.clone(),
        );
        let p = Pipeline::start(
            PipelineSpec {
                camera: "pool".into(),
                queue_depth: 2,
                max_in_flight: 2,
                stage: Stage::new(StageSpec::default(), None).unwrap(),
                keep_frames: false,
            },
            Box::new(src),
            pool.clone(),
            Arc::new(ReplayClock::default()),
            vec![],
            frames.clone(),
        )
        .unwrap();
        let allocs_before_join = p.allocations();
        let _ = allocs_before_join;
        let rep = p.join();
        assert_eq!(rep.stats.processed, n);
        frames.allocations()
    };
    let warm = run_frames(20, &frames);
    // bounded by what can be alive at once: queue + in flight + one being captured
    assert!(
        warm <= 2 + 2 + 2,
        "{warm} pixel buffers for a queue of 2 and 2 in flight"
    );
    // 200 more frames allocate at most up to the same bound (which of the warm-up's buffers are
    // alive at once depends on thread timing, so the count may still rise by one or two to it,
    // but never per frame).
    let after = run_frames(200, &frames);
    assert!(
        after >= warm && after <= 2 + 2 + 2,
        "steady state must reuse pixel buffers: {warm} after 20 frames, {after} after 220"
    );
}

#[test]
fn live_source_drops_oldest_when_compute_is_slow_and_counts_it() {
    // A live source at 2000 fps into one slow compute thread and a queue of 1.
    let pool = Arc::new(rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap());
    let frames = BufferPool::new(8);
    let src = SyntheticSource::with_pool(
        SyntheticSpec {
            width: 512,
            height: 512,
            frames: 60,
            fps: 1000.0,
            live: true,
            ..Default::default()
        },
        frames.clone(),
    );
    let sink = CollectSink::default();
    let p = Pipeline::start(
        PipelineSpec {
            camera: "live".into(),
            queue_depth: 1,
            max_in_flight: 1,
            stage: Stage::new(StageSpec::default(), None).unwrap(),
            keep_frames: false,
        },
        Box::new(src),
        pool,
        Arc::new(crate::clock::MonotonicClock),
        vec![sink.factory("live")],
        frames,
    )
    .unwrap();
    let r = p.join();
    let s = &r.stats;
    assert_eq!(s.captured, 60);
    assert_eq!(
        s.captured,
        s.processed + s.dropped_queue_full + s.failed_compute,
        "{s:?}"
    );
    // sequences leave in increasing order even with drops
    let seqs: Vec<u64> = sink
        .take()
        .iter()
        .filter_map(|r| r["sequence"].as_u64())
        .collect();
    assert!(seqs.windows(2).all(|w| w[0] < w[1]), "{seqs:?}");
    assert_eq!(seqs.len() as u64, s.processed);
}

/// A sink that fails on frame `at` (like the recorder on a full disk): with `interrupt`, as
/// [`super::engine::SinkError::Interrupted`] and going on (counting the later frames it gets in
/// `seen`, and not writing those of odd index), else as a write error that stops it. The frame it
/// fails on is not written either; with `counts_failing` its own count says so (as the recorder's
/// does), else the engine has to.
struct FailAt {
    at: u64,
    interrupt: bool,
    counts_failing: bool,
    seen: Arc<std::sync::atomic::AtomicU64>,
    not_written: u64,
}

impl FailAt {
    fn factory(
        at: u64,
        interrupt: bool,
        counts_failing: bool,
    ) -> (super::engine::SinkFactory, Arc<std::sync::atomic::AtomicU64>) {
        let seen = Arc::new(std::sync::atomic::AtomicU64::new(0));
        let s = seen.clone();
        let f: super::engine::SinkFactory = Box::new(move || {
            Ok(Box::new(FailAt {
                at,
                interrupt,
                counts_failing,
                seen: s,
                not_written: 0,
            }) as Box<dyn super::sinks::Sink>)
        });
        (f, seen)
    }
}

impl super::sinks::Sink for FailAt {
    fn name(&self) -> String {
        "fail-at".into()
    }
    fn frame(&mut self, r: &super::engine::FrameResult) -> Result<(), super::engine::SinkError> {
        let (sink, message) = (self.name(), "no space left on device".to_string());
        if r.index == self.at {
            self.not_written += u64::from(self.counts_failing);
            return Err(if self.interrupt {
                super::engine::SinkError::Interrupted { sink, message }
            } else {
                super::engine::SinkError::Write { sink, message }
            });
        }
        if r.index > self.at {
            self.seen.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            self.not_written += r.index % 2;
        }
        Ok(())
    }
    fn frames_not_written(&self) -> u64 {
        self.not_written
    }
    fn stats(&mut self, _: &crate::wire::messages::StatsMsg) -> Result<(), super::engine::SinkError> {
        Ok(())
    }
    fn finish(&mut self) -> Result<(), super::engine::SinkError> {
        Ok(())
    }
}

#[test]
fn a_sink_that_fails_is_counted_and_the_others_go_on() {
    let spec = || SyntheticSpec {
        width: 96,
        height: 64,
        frames: 12,
        ..Default::default()
    };
    // the frame a sink failed on is counted once, whether the sink counts it itself or not
    for counts_failing in [false, true] {
        let (failing, _) = FailAt::factory(3, false, counts_failing);
        let report = run_with(2, 2, spec(), vec![failing]).0;
        // frame 3 and frames 4..12, which reached the sink after it stopped
        assert_eq!(
            report.stats.sink_frames_lost, 9,
            "counts_failing {counts_failing}"
        );
    }
    let (failing, _) = FailAt::factory(3, false, false);
    let (report, records) = run_with(2, 2, spec(), vec![failing]);
    // The pipeline went on: every frame reached the healthy sink.
    assert_eq!(report.stats.processed, 12);
    assert_eq!(report.stats.failed_sink, 1);
    assert_eq!(report.sink_errors.len(), 1);
    assert!(
        report.sink_errors[0].contains("no space left"),
        "{:?}",
        report.sink_errors
    );
    assert_eq!(records.iter().filter(|r| r["type"] == "frame").count(), 12);
    // The stats the healthy sink received carry the counter (whether the failure is already in
    // them depends on the two sink threads' timing, so only its presence is checked here).
    let last = records.last().unwrap();
    assert_eq!(last["type"], "final_stats");
    assert!(last["failed_sink"].as_u64().is_some_and(|n| n <= 1), "{last}");
}

#[test]
fn an_interrupted_sink_is_counted_and_keeps_receiving_frames() {
    let (sink, seen) = FailAt::factory(3, true, true);
    let spec = SyntheticSpec {
        width: 96,
        height: 64,
        frames: 12,
        ..Default::default()
    };
    let (report, _) = run_with(2, 2, spec, vec![sink]);
    assert_eq!(report.stats.processed, 12);
    assert_eq!(report.stats.failed_sink, 1);
    assert!(report.sink_errors.is_empty(), "{:?}", report.sink_errors);
    assert_eq!(report.sink_interruptions.len(), 1);
    assert!(report.sink_interruptions[0].contains("no space left"));
    // the sink's own count, taken after every event: frame 3 and the odd ones of 4..12
    assert_eq!(report.stats.sink_frames_lost, 5);
    assert_eq!(
        seen.load(std::sync::atomic::Ordering::Relaxed),
        8,
        "frames 4..12 still reached the sink"
    );
}

/// A sink named `name` whose `frame` is `f` (stats and finish do nothing).
struct FnSink<F>(&'static str, F);

impl<F> super::sinks::Sink for FnSink<F>
where
    F: FnMut(&super::engine::FrameResult) -> Result<(), super::engine::SinkError>,
{
    fn name(&self) -> String {
        self.0.into()
    }
    fn frame(&mut self, r: &super::engine::FrameResult) -> Result<(), super::engine::SinkError> {
        (self.1)(r)
    }
    fn stats(&mut self, _: &crate::wire::messages::StatsMsg) -> Result<(), super::engine::SinkError> {
        Ok(())
    }
    fn finish(&mut self) -> Result<(), super::engine::SinkError> {
        Ok(())
    }
}

/// A factory of [`FnSink`].
fn fn_sink<F>(name: &'static str, f: F) -> super::engine::SinkFactory
where
    F: FnMut(&super::engine::FrameResult) -> Result<(), super::engine::SinkError> + Send + 'static,
{
    Box::new(move || Ok(Box::new(FnSink(name, f)) as Box<dyn super::sinks::Sink>))
}

#[test]
fn a_sink_that_panics_stops_like_a_failed_one_and_its_frames_are_counted() {
    let spec = SyntheticSpec {
        width: 96,
        height: 64,
        frames: 12,
        ..Default::default()
    };
    let panicking = fn_sink("panic-at", |r| {
        assert!(r.index != 3, "a bug in a sink (frame {})", r.index);
        Ok(())
    });
    let (report, records) = run_with(2, 2, spec, vec![panicking]);
    assert_eq!(report.stats.processed, 12);
    assert_eq!(report.stats.failed_sink, 1);
    assert_eq!(report.sink_errors.len(), 1, "{:?}", report.sink_errors);
    assert!(
        report.sink_errors[0].contains("sink panic-at panicked: a bug in a sink (frame 3)"),
        "{:?}",
        report.sink_errors
    );
    // frame 3 and frames 4..12, which reached the sink's thread after the panic
    assert_eq!(report.stats.sink_frames_lost, 9);
    assert_eq!(records.iter().filter(|r| r["type"] == "frame").count(), 12);
}

/// A source that plays a script: frames carrying a driver sequence number, and errors for the
/// buffers the driver delivered but that were not frames.
struct Scripted(std::collections::VecDeque<Result<crate::raw::RawFrame, crate::capture::CaptureError>>);

impl crate::capture::Source for Scripted {
    fn next_frame(&mut self) -> Result<Option<crate::raw::RawFrame>, crate::capture::CaptureError> {
        self.0.pop_front().transpose()
    }
    fn kind(&self) -> crate::capture::SourceKind {
        crate::capture::SourceKind::Replay
    }
    fn describe(&self) -> String {
        "scripted".into()
    }
}

/// Driver sequences 10, 11 (a failed buffer), 12, 15, 16 (failed), 17, then 3 (a restart) and 4:
/// the two failed buffers are counted once each, as failed, and only 13 and 14 as driver drops.
#[test]
fn a_failed_buffer_is_not_also_counted_as_a_driver_drop() {
    use crate::capture::CaptureError;
    use crate::raw::{Cfa, FrameMeta, Levels, RawFrame};
    let frame = |i: u64, sensor: u64| {
        Ok(
            RawFrame::from_u16(16, 8, vec![100; 128], Cfa::Rggb, 12, Levels::uniform(0, 4095))
                .unwrap()
                .with_meta(FrameMeta {
                    sequence: i,
                    sensor_sequence: Some(sensor),
                    timestamp_ns: i * 1_000_000,
                    source: Arc::from("scripted"),
                }),
        )
    };
    let bad = |sensor: u32| {
        Err(CaptureError::BadBuffer {
            path: "/dev/video0".into(),
            sequence: sensor,
            reason: "the driver marked it as failed".into(),
        })
    };
    let script = vec![
        frame(0, 10),
        bad(11),
        frame(1, 12),
        frame(2, 15),
        bad(16),
        frame(3, 17),
        frame(4, 3),
        frame(5, 4),
    ];
    let frames = BufferPool::new(4);
    let sink = CollectSink::default();
    let p = Pipeline::start(
        PipelineSpec {
            camera: "s".into(),
            queue_depth: 3,
            max_in_flight: 1,
            stage: Stage::new(StageSpec::default(), None).unwrap(),
            keep_frames: false,
        },
        Box::new(Scripted(script.into())),
        Arc::new(rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap()),
        Arc::new(ReplayClock::default()),
        vec![sink.factory("s")],
        frames,
    )
    .unwrap();
    let s = p.join().stats;
    assert_eq!((s.captured, s.processed), (6, 6), "{s:?}");
    assert_eq!(s.failed_source, 2, "{s:?}");
    assert_eq!(s.dropped_driver, 2, "13 and 14 only: {s:?}");
}

#[test]
fn an_aborted_drain_lets_the_other_sinks_finish_while_one_is_stuck() {
    use std::time::{Duration, Instant};
    let (entered_tx, entered) = crossbeam_channel::bounded(1);
    let (release, release_rx) = crossbeam_channel::bounded::<()>(0);
    // A sink that blocks in its first frame until released (a write that never returns).
    let stuck = fn_sink("stuck", move |_| {
        let _ = entered_tx.try_send(());
        let _ = release_rx.recv();
        Ok(())
    });
    let pool = Arc::new(rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap());
    let frames = BufferPool::new(16);
    let n = 100_000;
    let spec = SyntheticSpec {
        width: 16,
        height: 16,
        frames: n,
        ..Default::default()
    };
    let src = SyntheticSource::with_pool(spec, frames.clone());
    let sink = CollectSink::default();
    let p = Pipeline::start(
        PipelineSpec {
            camera: "t".into(),
            queue_depth: 3,
            max_in_flight: 2,
            stage: Stage::new(StageSpec::default(), None).unwrap(),
            keep_frames: false,
        },
        Box::new(src),
        pool,
        Arc::new(ReplayClock::default()),
        vec![stuck, sink.factory("t")],
        frames,
    )
    .unwrap();
    entered.recv_timeout(Duration::from_secs(10)).unwrap();
    // Let the stuck sink's queue fill and the pipeline behind it stop.
    std::thread::sleep(Duration::from_millis(300));
    p.stop();
    let abort = p.abort_handle();
    let join = std::thread::spawn(move || p.join());
    std::thread::sleep(Duration::from_millis(100));
    assert!(!join.is_finished(), "a stuck sink holds the drain");
    abort.abort();
    // The collecting sink gets the final stats and finishes although the stuck one never returns.
    let t0 = Instant::now();
    let is_final = |r: &serde_json::Value| r["type"] == "final_stats";
    while !sink.records.lock().unwrap().iter().any(is_final) {
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "the other sink never finished"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    release.send(()).unwrap();
    let report = join.join().unwrap();
    assert!(report.stats.processed < n, "the drain was cut short");
    assert!(
        report.stats.sink_frames_lost > 0,
        "the stuck sink's queued frames are counted as lost"
    );
}

/// A recorder stand-in: `Recording`, `Paused` from frame `pause_at` on, a write error at frame
/// `fail_at`.
struct Recorder {
    pause_at: Option<u64>,
    fail_at: Option<u64>,
    last: u64,
}

impl super::sinks::Sink for Recorder {
    fn name(&self) -> String {
        "recorder".into()
    }
    fn frame(&mut self, r: &super::engine::FrameResult) -> Result<(), super::engine::SinkError> {
        self.last = r.index;
        if self.fail_at == Some(r.index) {
            return Err(super::engine::SinkError::Write {
                sink: self.name(),
                message: "disk gone".into(),
            });
        }
        Ok(())
    }
    fn stats(&mut self, _: &crate::wire::messages::StatsMsg) -> Result<(), super::engine::SinkError> {
        Ok(())
    }
    fn finish(&mut self) -> Result<(), super::engine::SinkError> {
        Ok(())
    }
    fn recorder_state(&self) -> Option<super::stats::RecorderState> {
        Some(if self.pause_at.is_some_and(|p| self.last >= p) {
            super::stats::RecorderState::Paused
        } else {
            super::stats::RecorderState::Recording
        })
    }
}

#[test]
fn the_recorder_state_follows_the_recorder_sink_to_the_end_of_the_run() {
    use super::stats::RecorderState;
    let spec = SyntheticSpec {
        width: 32,
        height: 16,
        frames: 6,
        ..Default::default()
    };
    let state =
        |sinks: Vec<super::engine::SinkFactory>| run_with_stats(1, 2, spec.clone(), sinks).2.recorder_state();
    let rec = |pause_at, fail_at| -> super::engine::SinkFactory {
        Box::new(move || {
            Ok(Box::new(Recorder {
                pause_at,
                fail_at,
                last: 0,
            }) as Box<dyn super::sinks::Sink>)
        })
    };
    // No recorder: off, whatever the other sinks do.
    assert_eq!(state(Vec::new()), RecorderState::Off);
    // Finished cleanly; still paused at the end; stopped by a write error.
    assert_eq!(state(vec![rec(None, None)]), RecorderState::Finished);
    assert_eq!(state(vec![rec(Some(3), None)]), RecorderState::Paused);
    assert_eq!(state(vec![rec(None, Some(2))]), RecorderState::Failed);
}
