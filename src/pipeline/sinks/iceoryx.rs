//! The iceoryx2 sink: a camera's detections, gradients and stats publishers on one thread.
//!
//! Built inside its sink thread (iceoryx2 `ipc` ports are not `Send`). Sending never blocks: the
//! services use safe overflow, so a stalled subscriber loses its oldest samples instead of holding
//! the daemon back. When the sink finishes (shutdown), the final stats have been sent and dropping
//! the ports and node releases the shared memory.

use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;

use super::{FrameResult, Sink, SinkError, SinkFactory};
use crate::config::PublishConfig;
use crate::publish::service::{
    create_node, descriptors_service, detections_service, gradients_publisher, gradients_service,
    keypoints_service, publisher, root_dir, stats_service,
};
use crate::wire::messages::{BoxMsg, DescriptorsMsg, DetectionsMsg, GradientsHeader, KeypointsMsg, StatsMsg};

/// The gradients publisher, its decimation and a reusable staging buffer.
type GradientsPort = (Publisher<ipc::Service, [u8], GradientsHeader>, usize, Vec<u8>);

/// The publishers of one camera.
pub struct IceoryxSink {
    camera: String,
    // Field order matters for drop order: ports before their node.
    detections: Publisher<ipc::Service, DetectionsMsg, ()>,
    stats: Publisher<ipc::Service, StatsMsg, ()>,
    gradients: Option<GradientsPort>,
    keypoints: Option<Publisher<ipc::Service, KeypointsMsg, ()>>,
    descriptors: Option<Publisher<ipc::Service, DescriptorsMsg, ()>>,
    _node: Node<ipc::Service>,
}

impl IceoryxSink {
    /// A factory for the pipeline. `keypoints`: also publish the keypoints service
    /// (`compute.keypoints`); `descriptors`: and the descriptors service
    /// (`compute.keypoint_descriptors`).
    pub fn factory(camera: &str, cfg: &PublishConfig, keypoints: bool, descriptors: bool) -> SinkFactory {
        let (camera, cfg) = (camera.to_string(), cfg.clone());
        Box::new(move || {
            Self::new(&camera, &cfg, keypoints, descriptors)
                .map(|s| Box::new(s) as Box<dyn Sink>)
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
        let det_svc = detections_service(&node, p, camera, cfg.subscriber_buffer)?;
        let stats_svc = stats_service(&node, p, camera, cfg.subscriber_buffer)?;
        let detections = publisher(&det_svc, "detections")?;
        let stats = publisher(&stats_svc, "stats")?;
        let gradients = if cfg.gradients {
            let svc = gradients_service(&node, p, camera, cfg.subscriber_buffer)?;
            Some((gradients_publisher(&svc)?, cfg.gradients_decimation, Vec::new()))
        } else {
            None
        };
        let keypoints = if keypoints {
            let svc = keypoints_service(&node, p, camera, cfg.subscriber_buffer)?;
            Some(publisher(&svc, "keypoints")?)
        } else {
            None
        };
        let descriptors = if descriptors {
            let svc = descriptors_service(&node, p, camera, cfg.subscriber_buffer)?;
            Some(publisher(&svc, "descriptors")?)
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
            _node: node,
        })
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
pub fn keypoints_msg(r: &FrameResult) -> Option<KeypointsMsg> {
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
pub fn descriptors_msg(r: &FrameResult) -> Option<DescriptorsMsg> {
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
pub fn detections_msg(r: &FrameResult) -> DetectionsMsg {
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

    fn finish(&mut self) -> Result<(), SinkError> {
        Ok(())
    }
}
