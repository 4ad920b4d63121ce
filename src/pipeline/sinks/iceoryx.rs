//! The iceoryx2 sink: a camera's detections, gradients and stats publishers on one thread.
//!
//! Built inside its sink thread (iceoryx2 `ipc` ports are not `Send`). Sending never blocks: the
//! services use safe overflow, so a stalled subscriber loses its oldest samples instead of holding
//! the daemon back. When the sink finishes (end of a replay, shutdown), the final stats have been
//! sent and dropping the ports and node releases the shared memory.
//!
//! **Linger.** iceoryx2 connects a subscriber to a publisher in the subscriber's own `receive`, and
//! only while the publisher exists. A publisher sends into a connection of every subscriber
//! subscribed at send time, but when it is dropped, a connection its subscriber has not yet opened
//! is removed with the samples in it. So a subscriber that did not poll between the publishers'
//! creation and their drop (a replay of small frames takes milliseconds; a loaded machine can leave
//! a subscriber unscheduled that long) would lose the whole run, final stats included. `finish`
//! therefore keeps the publishers while any subscriber is still subscribed to one of the camera's
//! services, until none is left or [`FINAL_LINGER`] has passed (a `mosaicd listen --until-final`
//! leaves right after the final stats, so the daemon ends as soon as it has them). Without
//! subscribers it does not wait.

use std::time::{Duration, Instant};

use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;

use super::{FrameResult, Sink, SinkError, SinkFactory};
use crate::config::PublishConfig;
use crate::publish::service::{
    create_node, descriptors_service, detections_service, gradients_publisher, gradients_service,
    keypoints_service, publisher, root_dir, stats_service,
};
use crate::wire::messages::{BoxMsg, DescriptorsMsg, DetectionsMsg, GradientsHeader, KeypointsMsg, StatsMsg};

/// The longest [`IceoryxSink::finish`] keeps the publishers after the final stats for subscribers
/// still subscribed (see the module documentation). A subscriber that polls at least this often
/// receives everything up to the final stats (`mosaicd listen` and the Python client poll every
/// millisecond).
pub(crate) const FINAL_LINGER: Duration = Duration::from_millis(500);
/// How often the linger counts the subscribers.
const LINGER_POLL: Duration = Duration::from_millis(1);

/// The gradients publisher, its decimation and a reusable staging buffer.
type GradientsPort = (Publisher<ipc::Service, [u8], GradientsHeader>, usize, Vec<u8>);

/// The subscriber count of one of the camera's services (it owns the service's port factory).
type SubscriberCount = Box<dyn Fn() -> usize>;

/// The publishers of one camera.
pub struct IceoryxSink {
    camera: String,
    // Field order matters for drop order: ports before their node.
    detections: Publisher<ipc::Service, DetectionsMsg, ()>,
    stats: Publisher<ipc::Service, StatsMsg, ()>,
    gradients: Option<GradientsPort>,
    keypoints: Option<Publisher<ipc::Service, KeypointsMsg, ()>>,
    descriptors: Option<Publisher<ipc::Service, DescriptorsMsg, ()>>,
    /// One per service, for the linger.
    subscribers: Vec<SubscriberCount>,
    /// The longest `finish` waits for subscribers ([`FINAL_LINGER`] unless set otherwise).
    linger: Duration,
    _node: Node<ipc::Service>,
}

impl IceoryxSink {
    /// A factory for the pipeline. `keypoints`: also publish the keypoints service
    /// (`compute.keypoints`); `descriptors`: and the descriptors service
    /// (`compute.keypoint_descriptors`). The sink lingers up to `FINAL_LINGER` for subscribers.
    pub fn factory(camera: &str, cfg: &PublishConfig, keypoints: bool, descriptors: bool) -> SinkFactory {
        Self::factory_with_linger(camera, cfg, keypoints, descriptors, FINAL_LINGER)
    }

    /// [`IceoryxSink::factory`] with another linger (`Duration::ZERO`: drop the publishers right
    /// after the final stats, for a benchmark whose only subscriber never reads).
    pub fn factory_with_linger(
        camera: &str,
        cfg: &PublishConfig,
        keypoints: bool,
        descriptors: bool,
        linger: Duration,
    ) -> SinkFactory {
        let (camera, cfg) = (camera.to_string(), cfg.clone());
        Box::new(move || {
            Self::new(&camera, &cfg, keypoints, descriptors)
                .map(|s| Box::new(s.with_linger(linger)) as Box<dyn Sink>)
                .map_err(|e| SinkError::Start {
                    sink: format!("iceoryx2 {}/{camera}", cfg.service_prefix),
                    message: e.to_string(),
                })
        })
    }

    /// Create the node, services and publishers (`keypoints`: the keypoints service too;
    /// `descriptors`: the descriptors service too).
    pub fn new(
        camera: &str,
        cfg: &PublishConfig,
        keypoints: bool,
        descriptors: bool,
    ) -> Result<Self, crate::publish::service::PublishError> {
        let node = create_node(&format!("mosaicd-{camera}"), true, &root_dir(&cfg.root)?)?;
        let p = &cfg.service_prefix;
        let mut subscribers: Vec<SubscriberCount> = Vec::new();
        let det_svc = detections_service(&node, p, camera, cfg.subscriber_buffer)?;
        let stats_svc = stats_service(&node, p, camera, cfg.subscriber_buffer)?;
        let detections = publisher(&det_svc, "detections")?;
        let stats = publisher(&stats_svc, "stats")?;
        subscribers.push(Box::new(move || det_svc.dynamic_config().number_of_subscribers()));
        subscribers.push(Box::new(move || {
            stats_svc.dynamic_config().number_of_subscribers()
        }));
        let gradients = if cfg.gradients {
            let svc = gradients_service(&node, p, camera, cfg.subscriber_buffer)?;
            let port = (gradients_publisher(&svc)?, cfg.gradients_decimation, Vec::new());
            subscribers.push(Box::new(move || svc.dynamic_config().number_of_subscribers()));
            Some(port)
        } else {
            None
        };
        let keypoints = if keypoints {
            let svc = keypoints_service(&node, p, camera, cfg.subscriber_buffer)?;
            let port = publisher(&svc, "keypoints")?;
            subscribers.push(Box::new(move || svc.dynamic_config().number_of_subscribers()));
            Some(port)
        } else {
            None
        };
        let descriptors = if descriptors {
            let svc = descriptors_service(&node, p, camera, cfg.subscriber_buffer)?;
            let port = publisher(&svc, "descriptors")?;
            subscribers.push(Box::new(move || svc.dynamic_config().number_of_subscribers()));
            Some(port)
        } else {
            None
        };
        Ok(Self {
            camera: camera.into(),
            detections,
            stats,
            gradients,
            keypoints,
            descriptors,
            subscribers,
            linger: FINAL_LINGER,
            _node: node,
        })
    }

    /// The same sink with the linger `linger` instead of `FINAL_LINGER`.
    pub fn with_linger(mut self, linger: Duration) -> Self {
        self.linger = linger;
        self
    }

    /// Subscribers subscribed now to any of the camera's services (one that subscribes to two
    /// services counts twice).
    pub fn subscribers(&self) -> usize {
        self.subscribers.iter().map(|count| count()).sum()
    }

    fn werr(&self, what: &str, e: impl std::fmt::Display) -> SinkError {
        SinkError::Write {
            sink: format!("iceoryx2 {} {what}", self.camera),
            message: e.to_string(),
        }
    }

    /// Loan a sample from `pubr`, write `msg` into it and send it; errors name `what`.
    fn send<T: std::fmt::Debug + ZeroCopySend>(
        &self,
        pubr: &Publisher<ipc::Service, T, ()>,
        msg: T,
        what: &str,
    ) -> Result<(), SinkError> {
        let sample = pubr
            .loan_uninit()
            .map_err(|e| self.werr(&format!("{what} loan"), e))?;
        sample
            .write_payload(msg)
            .send()
            .map_err(|e| self.werr(&format!("{what} send"), e))?;
        Ok(())
    }
}

/// The keypoints message of a result (`None` when the stage computed no keypoints).
pub(crate) fn keypoints_msg(r: &FrameResult) -> Option<KeypointsMsg> {
    let kps = r.output.keypoints.as_ref()?;
    let mut m = KeypointsMsg {
        index: r.index,
        sequence: r.meta.sequence,
        capture_timestamp_ns: r.meta.timestamp_ns,
        publish_timestamp_ns: r.publish_timestamp_ns,
        frame_width: r.width as u32,
        frame_height: r.height as u32,
        ..KeypointsMsg::default()
    };
    m.set_keypoints(kps);
    Some(m)
}

/// The descriptors message of a result (`None` when the stage computed no descriptors).
pub(crate) fn descriptors_msg(r: &FrameResult) -> Option<DescriptorsMsg> {
    let d = r.output.descriptors.as_ref()?;
    let mut m = DescriptorsMsg {
        index: r.index,
        sequence: r.meta.sequence,
        capture_timestamp_ns: r.meta.timestamp_ns,
        ..DescriptorsMsg::default()
    };
    m.set_descriptors(d);
    Some(m)
}

/// The detections message of a result.
pub(crate) fn detections_msg(r: &FrameResult) -> DetectionsMsg {
    let mut m = DetectionsMsg {
        index: r.index,
        sequence: r.meta.sequence,
        sensor_sequence: r.meta.sensor_sequence.unwrap_or(u64::MAX),
        capture_timestamp_ns: r.meta.timestamp_ns,
        publish_timestamp_ns: r.publish_timestamp_ns,
        latency_ns: r.latency_ns,
        frame_width: r.width as u32,
        frame_height: r.height as u32,
        mean_magnitude: r.output.mean_magnitude,
        ..DetectionsMsg::default()
    };
    let boxes: Vec<BoxMsg> = r.output.detections.iter().map(BoxMsg::from).collect();
    m.set_boxes(&boxes);
    m
}

impl Sink for IceoryxSink {
    fn name(&self) -> String {
        format!("iceoryx2 {}", self.camera)
    }

    fn frame(&mut self, r: &FrameResult) -> Result<(), SinkError> {
        // Keypoints and descriptors first: a subscriber that has a frame's detections has its
        // keypoints too.
        if let (Some(pubr), Some(msg)) = (self.keypoints.as_ref(), keypoints_msg(r)) {
            self.send(pubr, msg, "keypoints")?;
        }
        if let (Some(pubr), Some(msg)) = (self.descriptors.as_ref(), descriptors_msg(r)) {
            self.send(pubr, msg, "descriptors")?;
        }
        self.send(&self.detections, detections_msg(r), "detections")?;
        if let Some((pubr, dec, buf)) = self.gradients.as_mut() {
            let maps = r.maps.get();
            let (dw, dh) = (maps.width.div_ceil(*dec), maps.height.div_ceil(*dec));
            buf.clear();
            for y in (0..maps.height).step_by(*dec) {
                for x in (0..maps.width).step_by(*dec) {
                    buf.extend_from_slice(&maps.magnitude[y * maps.width + x].to_le_bytes());
                }
            }
            for y in (0..maps.height).step_by(*dec) {
                for x in (0..maps.width).step_by(*dec) {
                    buf.push(maps.bins[y * maps.width + x]);
                }
            }
            let header = GradientsHeader {
                index: r.index,
                capture_timestamp_ns: r.meta.timestamp_ns,
                width: dw as u32,
                height: dh as u32,
                decimation: *dec as u32,
                mag_shift: maps.mag_shift,
                reserved: 0,
                orientation_bins: maps.orientation_bins as u32,
            };
            let mut sample = pubr.loan_slice_uninit(buf.len()).map_err(|e| SinkError::Write {
                sink: format!("iceoryx2 {} gradients", self.camera),
                message: e.to_string(),
            })?;
            *sample.user_header_mut() = header;
            let sample = sample.write_from_slice(buf);
            sample.send().map_err(|e| SinkError::Write {
                sink: format!("iceoryx2 {} gradients", self.camera),
                message: e.to_string(),
            })?;
        }
        Ok(())
    }

    fn stats(&mut self, s: &StatsMsg) -> Result<(), SinkError> {
        self.send(&self.stats, *s, "stats")
    }

    /// Linger (module documentation): keep the publishers until no subscriber is left or
    /// `linger` has passed.
    fn finish(&mut self) -> Result<(), SinkError> {
        let start = Instant::now();
        while self.subscribers() > 0 && start.elapsed() < self.linger {
            std::thread::sleep(LINGER_POLL);
        }
        let left = self.subscribers();
        tracing::debug!(
            camera = %self.camera,
            waited_ms = start.elapsed().as_millis() as u64,
            subscribers_left = left,
            "iceoryx2 publishers dropped"
        );
        Ok(())
    }
}
