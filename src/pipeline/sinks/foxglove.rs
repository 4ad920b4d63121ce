//! The live view: results and a preview of every frame to the Foxglove app over a WebSocket, through
//! Foxglove's own SDK (the `foxglove` crate's WebSocket server and message types), opt-in with
//! `[foxglove] listen`.
//!
//! One server per process ([`LiveView`], started before the pipelines, stopped after them) and one
//! [`FoxgloveSink`] per camera on its own sink thread. Per frame, on channels named after the
//! camera (the same topics as a recording, [`crate::wire::Topics`]):
//!
//! | topic | schema | content |
//! |---|---|---|
//! | `/<camera>/preview` | `foxglove.RawImage` (protobuf) | the 8-bit `bayer_*8` mosaic preview ([`crate::record::preview`]), every `preview_decimation`-th 2x2 tile |
//! | `/<camera>/annotations` | `foxglove.ImageAnnotations` (protobuf) | the boxes (LINE_LOOP) and scores (texts) in preview coordinates, same timestamp as the image |
//! | `/<camera>/keypoints` | `foxglove.ImageAnnotations` (protobuf) | with `compute.keypoints`: the mosaic SIFT keypoints (POINTS), preview coordinates |
//! | `/<camera>/stats` | `mosaicd.Stats` (JSON) | the pipeline stats and the live view's own counters (`"live"`) |
//!
//! Timestamps (message and log time) are the frame's capture timestamp, as in a recording;
//! `frame_id` is the camera name.
//!
//! ## Never blocking compute
//!
//! The sink does nothing for a channel no client subscribes to (no preview is made when nobody
//! watches it). Sending is the SDK's: each message is encoded once and queued per subscribed
//! client without waiting ([`foxglove::WebSocketServer::message_backlog_size`] =
//! `foxglove.client_backlog`); the client's own task writes its queue to its socket. A client
//! that reads too slowly, or has vanished without closing its connection, fills only its own
//! queue, and the SDK then drops that client's oldest messages: the others, the sink and compute
//! go on. The cost left on the sink thread is the preview and the encoding (measured in
//! `benches/live_view.rs`).
//!
//! What the SDK (0.30) does not report is how many messages it dropped for one client: its
//! queues are private. The live view counts what it published and to how many clients
//! ([`LiveCounters`], in the `"live"` group of the stats it publishes and in the log when it
//! ends), and each annotations message carries the frame's sequence number (metadata
//! `sequence`), so a client counts its own gaps against `live.frames_published`.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use foxglove::messages::{ImageAnnotations, KeyValuePair, RawImage, Timestamp};
use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{Channel, Context, RawChannel, Schema, WebSocketServer, WebSocketServerHandle};

use super::{FrameResult, Sink, SinkError, SinkFactory};
use crate::config::FoxgloveConfig;
use crate::record::preview::preview_from_raw;
use crate::wire::messages::StatsMsg;
use crate::wire::schema::{self, STATS_JSON_SCHEMA, STATS_SCHEMA};
use crate::wire::Topics;

/// Errors starting the live view.
#[derive(Debug, thiserror::Error)]
pub enum LiveViewError {
    /// `foxglove.listen` is not an address (validated with the config; here for callers that
    /// build one by hand).
    #[error("live view: {0}")]
    Config(#[from] crate::config::ConfigError),
    /// The runtime for the server could not be built.
    #[error("live view: cannot start its runtime: {0}")]
    Runtime(#[source] std::io::Error),
    /// The server could not bind or start.
    #[error("live view: cannot listen on {addr} (foxglove.listen): {source}")]
    Start {
        /// The address asked for.
        addr: SocketAddr,
        /// Cause.
        #[source]
        source: foxglove::FoxgloveError,
    },
}

/// Client counts, kept by the server's listener and read by the sinks.
#[derive(Debug, Default)]
pub(crate) struct ClientCounts {
    /// Clients connected now.
    pub connected: AtomicU64,
    /// Clients that connected since the start.
    pub total: AtomicU64,
    /// Channel subscriptions held now, over all clients.
    pub subscriptions: AtomicU64,
}

/// Updates [`ClientCounts`] from the server's callbacks (they run on the clients' tasks and only
/// touch atomics).
struct Listener(Arc<ClientCounts>);

impl ServerListener for Listener {
    fn on_client_connect(&self) {
        self.0.connected.fetch_add(1, Ordering::Relaxed);
        self.0.total.fetch_add(1, Ordering::Relaxed);
    }
    fn on_client_disconnect(&self) {
        self.0.connected.fetch_sub(1, Ordering::Relaxed);
    }
    fn on_subscribe(&self, _client: Client, _channel: ChannelView) {
        self.0.subscriptions.fetch_add(1, Ordering::Relaxed);
    }
    fn on_unsubscribe(&self, _client: Client, _channel: ChannelView) {
        self.0.subscriptions.fetch_sub(1, Ordering::Relaxed);
    }
}

/// The live view's server: one per process, shared by the cameras' sinks.
pub struct LiveView {
    ctx: Arc<Context>,
    handle: Option<WebSocketServerHandle>,
    /// The server's tasks run here (one worker thread, `mosaicd-foxglove`), apart from the
    /// daemon's runtime and the compute pool.
    runtime: tokio::runtime::Runtime,
    addr: SocketAddr,
    clients: Arc<ClientCounts>,
    decimation: usize,
}

impl std::fmt::Debug for LiveView {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveView")
            .field("addr", &self.addr)
            .finish_non_exhaustive()
    }
}

impl LiveView {
    /// Start the server of `cfg` (`None` when `foxglove.listen` is unset: no live view).
    pub fn start(cfg: &FoxgloveConfig) -> Result<Option<Self>, LiveViewError> {
        let Some(addr) = cfg.listen else {
            return Ok(None);
        };
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("mosaicd-foxglove")
            .enable_all()
            .build()
            .map_err(LiveViewError::Runtime)?;
        let ctx = Context::new();
        let clients = Arc::new(ClientCounts::default());
        let host = match addr {
            SocketAddr::V4(a) => a.ip().to_string(),
            SocketAddr::V6(a) => format!("[{}]", a.ip()),
        };
        let server = WebSocketServer::new()
            .name("mosaicd")
            .context(&ctx)
            .bind(host, addr.port())
            .message_backlog_size(cfg.client_backlog)
            .listener(Arc::new(Listener(clients.clone())));
        let handle = runtime
            .block_on(server.start())
            .map_err(|source| LiveViewError::Start { addr, source })?;
        let bound = SocketAddr::new(addr.ip(), handle.port());
        tracing::info!("live view: Foxglove WebSocket server on ws://{bound} (foxglove.listen)");
        Ok(Some(Self {
            ctx,
            handle: Some(handle),
            runtime,
            addr: bound,
            clients,
            decimation: cfg.preview_decimation.max(1) as usize,
        }))
    }

    /// The address the server listens on (the port resolved when `listen` asked for port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Clients connected now.
    pub fn clients(&self) -> u64 {
        self.clients.connected.load(Ordering::Relaxed)
    }

    /// The sink of camera `camera` (`keypoints`: also the keypoints channel).
    pub fn sink_factory(&self, camera: &str, keypoints: bool) -> SinkFactory {
        let (ctx, clients, camera, decimation) = (
            self.ctx.clone(),
            self.clients.clone(),
            camera.to_string(),
            self.decimation,
        );
        Box::new(move || {
            FoxgloveSink::new(&ctx, clients, &camera, decimation, keypoints)
                .map(|s| Box::new(s) as Box<dyn Sink>)
        })
    }

    /// Stop the server: clients are disconnected, the port is closed.
    pub fn stop(mut self) {
        if let Some(h) = self.handle.take() {
            let done = h.stop();
            self.runtime.block_on(done.wait());
        }
    }
}

/// What one camera's live view published, cumulative.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub(crate) struct LiveCounters {
    /// Frames the sink received.
    pub frames: u64,
    /// Frames published to at least one client (an image or annotations).
    pub frames_published: u64,
    /// Preview images published.
    pub images_published: u64,
    /// Frames a client subscribed to the preview of, that had no image to show (smaller than
    /// one decimated 2x2 tile, or the pipeline kept no frame).
    pub images_missing: u64,
    /// Frames no client subscribed to anything of (nothing was made for them).
    pub frames_unwatched: u64,
}

/// One camera's live view channels, on its sink thread.
pub(crate) struct FoxgloveSink {
    camera: String,
    decimation: usize,
    preview: Channel<RawImage>,
    annotations: Channel<ImageAnnotations>,
    keypoints: Option<Channel<ImageAnnotations>>,
    stats: Arc<RawChannel>,
    clients: Arc<ClientCounts>,
    counters: LiveCounters,
}

impl FoxgloveSink {
    fn new(
        ctx: &Arc<Context>,
        clients: Arc<ClientCounts>,
        camera: &str,
        decimation: usize,
        keypoints: bool,
    ) -> Result<Self, SinkError> {
        let topics = Topics::new(camera);
        let stats = ctx
            .channel_builder(topics.stats.as_str())
            .message_encoding("json")
            .schema(Schema::new(
                STATS_SCHEMA,
                "jsonschema",
                STATS_JSON_SCHEMA.as_bytes(),
            ))
            .build_raw()
            .map_err(|e| SinkError::Start {
                sink: format!("foxglove {camera}"),
                message: e.to_string(),
            })?;
        Ok(Self {
            camera: camera.to_string(),
            decimation,
            preview: ctx.channel_builder(topics.preview.as_str()).build(),
            annotations: ctx.channel_builder(topics.annotations.as_str()).build(),
            keypoints: keypoints.then(|| ctx.channel_builder(topics.keypoints.as_str()).build()),
            stats,
            clients,
            counters: LiveCounters::default(),
        })
    }

    /// The counters so far.
    #[cfg(test)]
    pub(crate) fn counters(&self) -> LiveCounters {
        self.counters
    }

    /// The preview of a result, if it has a frame large enough.
    fn preview_of(&self, r: &FrameResult) -> Option<RawImage> {
        let f = r.frame.as_ref()?;
        let pv = preview_from_raw(f, self.decimation)?;
        Some(RawImage {
            timestamp: Some(timestamp(r.meta.timestamp_ns)),
            frame_id: self.camera.clone(),
            width: pv.width as u32,
            height: pv.height as u32,
            encoding: f.cfa().foxglove_encoding(false).to_string(),
            step: pv.width as u32,
            data: pv.data.into(),
        })
    }
}

/// A capture timestamp as Foxglove's.
fn timestamp(ns: u64) -> Timestamp {
    schema::FoxgloveTime::from_ns(ns).into()
}

impl Sink for FoxgloveSink {
    fn name(&self) -> String {
        format!("foxglove {}", self.camera)
    }

    fn frame(&mut self, r: &FrameResult) -> Result<(), SinkError> {
        self.counters.frames += 1;
        let t = r.meta.timestamp_ns;
        let scale = self.decimation as f64;
        let mut published = false;
        if self.preview.has_sinks() {
            match self.preview_of(r) {
                Some(img) => {
                    self.preview.log_with_time(&img, t);
                    self.counters.images_published += 1;
                    published = true;
                }
                None => self.counters.images_missing += 1,
            }
        }
        if self.annotations.has_sinks() {
            let ann = schema::annotations_from_detections(t, &r.output.detections, scale);
            let mut msg = ImageAnnotations::from(&ann);
            msg.metadata.push(KeyValuePair {
                key: "sequence".into(),
                value: r.meta.sequence.to_string(),
            });
            self.annotations.log_with_time(&msg, t);
            published = true;
        }
        if let (Some(ch), Some(kps)) = (&self.keypoints, &r.output.keypoints) {
            if ch.has_sinks() {
                let ann = schema::annotations_from_keypoints(t, kps, scale);
                ch.log_with_time(&ImageAnnotations::from(&ann), t);
                published = true;
            }
        }
        if published {
            self.counters.frames_published += 1;
        } else {
            self.counters.frames_unwatched += 1;
        }
        Ok(())
    }

    fn stats(&mut self, s: &StatsMsg) -> Result<(), SinkError> {
        if !self.stats.has_sinks() {
            return Ok(());
        }
        let mut v = super::stats_json(&self.camera, s);
        v["live"] = serde_json::json!({
            "clients": self.clients.connected.load(Ordering::Relaxed),
            "clients_total": self.clients.total.load(Ordering::Relaxed),
            "subscriptions": self.clients.subscriptions.load(Ordering::Relaxed),
            "frames": self.counters.frames,
            "frames_published": self.counters.frames_published,
            "images_published": self.counters.images_published,
            "images_missing": self.counters.images_missing,
            "frames_unwatched": self.counters.frames_unwatched,
        });
        let json = serde_json::to_vec(&v).map_err(|e| SinkError::Write {
            sink: self.name(),
            message: e.to_string(),
        })?;
        self.stats
            .log_with_meta(&json, foxglove::PartialMetadata::with_log_time(s.timestamp_ns));
        Ok(())
    }

    fn finish(&mut self) -> Result<(), SinkError> {
        let c = self.counters;
        tracing::info!(
            camera = %self.camera,
            frames = c.frames,
            frames_published = c.frames_published,
            images_published = c.images_published,
            images_missing = c.images_missing,
            frames_unwatched = c.frames_unwatched,
            clients_total = self.clients.total.load(Ordering::Relaxed),
            "live view finished"
        );
        self.preview.close();
        self.annotations.close();
        if let Some(k) = &self.keypoints {
            k.close();
        }
        self.stats.close();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use foxglove::{Decode, FoxgloveError, Metadata, SinkId};

    use super::*;
    use crate::geometry::Detection;
    use crate::pipeline::sinks::PooledMaps;
    use crate::pipeline::stage::StageOutput;
    use crate::raw::{Cfa, FrameMeta, Levels, RawFrame};

    /// A subscriber of every channel that keeps what it is sent: (topic, log time, payload).
    struct Recorder(SinkId, Mutex<Vec<(String, u64, Vec<u8>)>>);

    impl foxglove::Sink for Recorder {
        fn id(&self) -> SinkId {
            self.0
        }
        fn log(&self, channel: &RawChannel, msg: &[u8], metadata: &Metadata) -> Result<(), FoxgloveError> {
            let entry = (channel.topic().to_string(), metadata.log_time, msg.to_vec());
            self.1.lock().unwrap().push(entry);
            Ok(())
        }
    }

    fn result(ts: u64) -> FrameResult {
        let f = RawFrame::from_u16(8, 8, vec![4095; 64], Cfa::Grbg, 12, Levels::uniform(0, 4095)).unwrap();
        FrameResult {
            camera: Arc::from("cam"),
            index: 3,
            meta: FrameMeta {
                sequence: 7,
                sensor_sequence: None,
                timestamp_ns: ts,
                source: Arc::from("test"),
            },
            width: 8,
            height: 8,
            output: StageOutput {
                detections: vec![Detection {
                    x: 2.0,
                    y: 2.0,
                    width: 4.0,
                    height: 4.0,
                    score: 0.5,
                }],
                keypoints: None,
                descriptors: None,
                mean_magnitude: 0.0,
            },
            maps: PooledMaps {
                maps: None,
                pool: None,
            },
            frame: Some(Arc::new(f)),
            publish_timestamp_ns: ts,
            latency_ns: 0,
        }
    }

    #[test]
    fn nothing_is_made_without_a_subscriber_and_image_and_boxes_share_the_frame_time() {
        let ctx = Context::new();
        let clients = Arc::new(ClientCounts::default());
        let mut sink = FoxgloveSink::new(&ctx, clients, "cam", 2, false).unwrap();
        sink.frame(&result(1_000)).unwrap();
        assert_eq!(
            sink.counters(),
            LiveCounters {
                frames: 1,
                frames_unwatched: 1,
                ..LiveCounters::default()
            }
        );
        let rec = Arc::new(Recorder(SinkId::next(), Mutex::default()));
        ctx.add_sink(rec.clone());
        sink.frame(&result(2_500_000_000)).unwrap();
        let c = sink.counters();
        assert_eq!((c.frames, c.frames_published, c.images_published), (2, 1, 1));
        let got = rec.1.lock().unwrap();
        let topics: Vec<&str> = got.iter().map(|(t, _, _)| t.as_str()).collect();
        assert_eq!(topics, ["/cam/preview", "/cam/annotations"]);
        assert!(got.iter().all(|(_, t, _)| *t == 2_500_000_000));
        let img = RawImage::decode(got[0].2.as_slice()).unwrap();
        // 8x8 decimated by 2 (whole 2x2 tiles): 4x4, full white.
        assert_eq!(
            (img.width, img.height, img.encoding.as_str()),
            (4, 4, "bayer_grbg8")
        );
        assert_eq!(img.data.as_ref(), &[255u8; 16][..]);
        assert_eq!(img.timestamp.unwrap().total_nanos(), 2_500_000_000);
        let ann = ImageAnnotations::decode(got[1].2.as_slice()).unwrap();
        // Preview coordinates: the full-frame box (2, 2)-(6, 6) halved.
        let corners: Vec<(f64, f64)> = ann.points[0].points.iter().map(|p| (p.x, p.y)).collect();
        assert_eq!(corners, [(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)]);
        assert_eq!(ann.metadata[0].value, "7");
    }
}
