//! iceoryx2 publishing and the `#[repr(C)]` message types subscribers read.
//!
//! Services (all `ipc`, i.e. shared memory between processes) are named
//! `<prefix>/<camera>/<topic>` ([`service_name`]):
//!
//! * `detections`: [`messages::DetectionsMsg`], one per processed frame, fixed size;
//! * `gradients` (optional): `[u8]` slices with a [`messages::GradientsHeader`] user header;
//! * `stats`: [`messages::StatsMsg`], one per stats interval and a final one.
//!
//! Every service is created with **safe overflow** (a full subscriber buffer overwrites its oldest
//! sample): a subscriber that stalls or dies can never block the daemon. The buffer depth is
//! `publish.subscriber_buffer`; late subscribers get the last samples as history. Stale resources
//! left by a killed daemon are removed when the next node is created (iceoryx2's dead-node cleanup,
//! which [`create_node`] also triggers explicitly and logs).
//!
//! iceoryx2 ports are not `Send`, so each camera's publishers live in their own sink thread
//! ([`crate::pipeline::IceoryxSink`]). `mosaicd listen` (the subscriber helpers: [`subscriber`], [`root_dir`], …) is a subscriber in another
//! process that only needs [`messages`].

/// Re-exported from [`crate::wire`], where the message types live.
pub use crate::wire::messages;
pub(crate) mod service;

pub use service::{
    create_node, descriptors_service, detections_service, gradients_service, keypoints_service, publisher,
    resolve_root, root_dir, segment_prefix, service_name, stats_service, subscriber, PublishError, RootEnv,
    RootOrigin,
};
