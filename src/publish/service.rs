//! Service names and builders shared by the daemon's publishers and any subscriber.
//!
//! Both sides call the same builder with the same settings (`open_or_create`), so whichever starts
//! first creates the service and the other opens it; a subscriber asking for a larger buffer than
//! the service offers gets a clear incompatibility error.
//!
//! ```
//! use mosaicd::publish::service::service_name;
//! assert_eq!(service_name("mosaicd", "front", "detections"), "mosaicd/front/detections");
//! ```

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;

use super::messages::{DescriptorsMsg, DetectionsMsg, GradientsHeader, KeypointsMsg, StatsMsg};

/// Publishers per service (one daemon, plus room for a restarted one while the old is cleaned).
const MAX_PUBLISHERS: usize = 2;
/// Subscribers per service.
const MAX_SUBSCRIBERS: usize = 16;
/// Samples kept for late subscribers.
const HISTORY: usize = 1;
/// Initial slice length of a gradients sample; grows as needed (power-of-two reallocation).
const GRADIENTS_INITIAL_SLICE: usize = 1 << 16;

/// Errors of the iceoryx2 layer, with what was being done.
#[derive(Debug, thiserror::Error)]
#[error("iceoryx2: {context}: {message}")]
pub struct PublishError {
    /// What was being done (service name, operation).
    pub context: String,
    /// iceoryx2's error.
    pub message: String,
}

fn err(context: impl Into<String>, e: impl std::fmt::Display) -> PublishError {
    PublishError {
        context: context.into(),
        message: e.to_string(),
    }
}

/// `<prefix>/<camera>/<topic>`.
pub fn service_name(prefix: &str, camera: &str, topic: &str) -> String {
    format!("{prefix}/{camera}/{topic}")
}

/// Create an ipc node (`daemon = true`: signals are left to the daemon's own handlers). Dead nodes
/// of crashed processes, and their services' shared memory, are cleaned up here.
pub fn create_node(name: &str, daemon: bool) -> Result<Node<ipc::Service>, PublishError> {
    let node_name: NodeName = name
        .try_into()
        .map_err(|e| err(format!("node name {name:?}"), format!("{e:?}")))?;
    let mode = if daemon {
        SignalHandlingMode::Disabled
    } else {
        SignalHandlingMode::HandleTerminationRequests
    };
    // iceoryx2 warns on stderr that no config file was loaded (its defaults are what we want);
    // keep its log to errors unless IOX2_LOG_LEVEL says otherwise.
    set_log_level_from_env_or(LogLevel::Error);
    let node = NodeBuilder::new()
        .name(&node_name)
        .signal_handling_mode(mode)
        .create::<ipc::Service>()
        .map_err(|e| err("create node", e))?;
    let cleaned = node.try_cleanup_dead_nodes();
    if cleaned.cleanups > 0 || cleaned.failed_cleanups > 0 {
        tracing::info!(
            cleaned = cleaned.cleanups,
            failed = cleaned.failed_cleanups,
            "removed stale iceoryx2 resources of dead processes"
        );
    }
    Ok(node)
}

fn name(prefix: &str, camera: &str, topic: &str) -> Result<ServiceName, PublishError> {
    let s = service_name(prefix, camera, topic);
    s.as_str()
        .try_into()
        .map_err(|e| err(format!("service name {s:?}"), format!("{e:?}")))
}

/// A fixed-size publish-subscribe service `<prefix>/<camera>/<topic>` with the daemon's settings
/// (safe overflow, history, publisher and subscriber limits).
fn fixed_service<T: std::fmt::Debug + ZeroCopySend>(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    topic: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, T, ()>, PublishError> {
    node.service_builder(&name(prefix, camera, topic)?)
        .publish_subscribe::<T>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(buffer)
        .history_size(HISTORY)
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(MAX_SUBSCRIBERS)
        .open_or_create()
        .map_err(|e| err(service_name(prefix, camera, topic), e))
}

/// The detections service.
pub fn detections_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, DetectionsMsg, ()>, PublishError> {
    fixed_service(node, prefix, camera, "detections", buffer)
}

/// The stats service.
pub fn stats_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, StatsMsg, ()>, PublishError> {
    fixed_service(node, prefix, camera, "stats", buffer)
}

/// The keypoints service (mosaic SIFT keypoints, `compute.keypoints = true`).
pub fn keypoints_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, KeypointsMsg, ()>, PublishError> {
    fixed_service(node, prefix, camera, "keypoints", buffer)
}

/// The descriptors service (SIFT descriptors of the keypoints, `compute.keypoint_descriptors`).
pub fn descriptors_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, DescriptorsMsg, ()>, PublishError> {
    fixed_service(node, prefix, camera, "descriptors", buffer)
}

/// The gradients service (dynamic `[u8]` slices with a header).
pub fn gradients_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    camera: &str,
    buffer: usize,
) -> Result<PortFactory<ipc::Service, [u8], GradientsHeader>, PublishError> {
    node.service_builder(&name(prefix, camera, "gradients")?)
        .publish_subscribe::<[u8]>()
        .user_header::<GradientsHeader>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(buffer)
        .history_size(HISTORY)
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(MAX_SUBSCRIBERS)
        .open_or_create()
        .map_err(|e| err(service_name(prefix, camera, "gradients"), e))
}

/// A publisher on a fixed-size service.
pub fn publisher<T: std::fmt::Debug + ZeroCopySend>(
    svc: &PortFactory<ipc::Service, T, ()>,
    what: &str,
) -> Result<Publisher<ipc::Service, T, ()>, PublishError> {
    svc.publisher_builder()
        .create()
        .map_err(|e| err(format!("{what} publisher"), e))
}

/// A publisher of gradient slices (grows its slices on demand).
pub fn gradients_publisher(
    svc: &PortFactory<ipc::Service, [u8], GradientsHeader>,
) -> Result<Publisher<ipc::Service, [u8], GradientsHeader>, PublishError> {
    svc.publisher_builder()
        .initial_max_slice_len(GRADIENTS_INITIAL_SLICE)
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .map_err(|e| err("gradients publisher", e))
}

/// A subscriber on a fixed-size service.
pub fn subscriber<T: std::fmt::Debug + ZeroCopySend>(
    svc: &PortFactory<ipc::Service, T, ()>,
    buffer: usize,
    what: &str,
) -> Result<Subscriber<ipc::Service, T, ()>, PublishError> {
    svc.subscriber_builder()
        .buffer_size(buffer)
        .create()
        .map_err(|e| err(format!("{what} subscriber"), e))
}
