//! The live view's WebSocket client, shared by `tests/live_foxglove.rs` and
//! `examples/live_view_picture.rs`: start a daemon and find its address, connect as the Foxglove
//! app does (subprotocol `foxglove.sdk.v1`), read the channel advertisements, subscribe, decode
//! message data, and draw a received image with its boxes.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use foxglove::messages::{ImageAnnotations, RawImage};
use futures_util::{SinkExt, StreamExt};
use mosaicd::geometry::Detection;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::tungstenite::Message;

/// How long any one step may take (a debug build detects a 768x512 frame in well under this).
pub const STEP: Duration = Duration::from_secs(60);

/// A daemon with the live view on a free port; killed when dropped.
pub struct Daemon {
    /// The process.
    pub child: Child,
    /// The live view's address, `ws://host:port`.
    pub url: String,
    /// Its log lines, as they come.
    pub log: mpsc::Receiver<String>,
}

impl Drop for Daemon {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A daemon config: a `files` camera `name` looping the image `path` at 10 frames/s (paced), the
/// live view on a free port with every 2x2 tile in the preview, no iceoryx2 publishing, two
/// compute threads; `daemon` and `foxglove` are more lines for those tables.
pub fn live_config(name: &str, path: &Path, daemon: &str, foxglove: &str) -> String {
    format!(
        r#"[daemon]
threads = 2
{daemon}[publish]
enabled = false
[foxglove]
listen = "127.0.0.1:0"
preview_decimation = 1
{foxglove}[[camera]]
name = "{name}"
source = "files"
path = {path:?}
fps = 10.0
realtime = true
loop = true
"#
    )
}

/// Start `mosaicd run --config cfg` (the binary `bin`, logging at info level, stderr read into
/// [`Daemon::log`]) and wait (up to [`STEP`]) for the live view's address in its log.
pub fn spawn_daemon(bin: &Path, cfg: &Path) -> Daemon {
    let mut child = Command::new(bin)
        .args(["run", "--config"])
        .arg(cfg)
        .env("RUST_LOG", "info")
        .env("NO_COLOR", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Every log line goes to the channel (the daemon must never block on a full pipe).
    let (tx, log) = mpsc::channel();
    let stderr = child.stderr.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let deadline = Instant::now() + STEP;
    let url = loop {
        let line = log
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            .expect("the daemon logs its live view address");
        if let Some(at) = line.find("ws://") {
            let url: String = line[at..].chars().take_while(|c| !c.is_whitespace()).collect();
            break url;
        }
    };
    Daemon { child, url, log }
}

/// A client connection.
pub type Ws = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// Connect as the Foxglove app does: the SDK's subprotocol in the handshake. `recv_buffer`: a
/// small receive buffer (bytes), so that a client that stops reading fills its socket quickly.
pub async fn connect(url: &str, recv_buffer: Option<u32>) -> Ws {
    let addr: std::net::SocketAddr = url.trim_start_matches("ws://").parse().unwrap();
    let socket = tokio::net::TcpSocket::new_v4().unwrap();
    if let Some(n) = recv_buffer {
        socket.set_recv_buffer_size(n).unwrap();
    }
    let stream = socket.connect(addr).await.unwrap();
    let mut req = url.into_client_request().unwrap();
    req.headers_mut()
        .insert("sec-websocket-protocol", "foxglove.sdk.v1".parse().unwrap());
    let (ws, resp) = tokio_tungstenite::client_async(req, tokio_tungstenite::MaybeTlsStream::Plain(stream))
        .await
        .unwrap();
    assert_eq!(
        resp.headers().get("sec-websocket-protocol").unwrap(),
        "foxglove.sdk.v1"
    );
    ws
}

/// The next WebSocket message (within [`STEP`]).
pub async fn next_message(ws: &mut Ws) -> Message {
    let msg = tokio::time::timeout(STEP, ws.next()).await;
    msg.expect("a message in time")
        .expect("the connection is open")
        .unwrap()
}

/// Read the advertisements until `topics` are all there; their channel ids, in order.
pub async fn channels(ws: &mut Ws, topics: &[&str]) -> Vec<(u64, String, String)> {
    let mut found: Vec<Option<(u64, String, String)>> = vec![None; topics.len()];
    while found.iter().any(Option::is_none) {
        let msg = next_message(ws).await;
        let Message::Text(text) = msg else { continue };
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        if v["op"] != "advertise" {
            continue;
        }
        for ch in v["channels"].as_array().unwrap() {
            if let Some(i) = topics.iter().position(|t| ch["topic"] == *t) {
                found[i] = Some((
                    ch["id"].as_u64().unwrap(),
                    ch["schemaName"].as_str().unwrap().to_string(),
                    ch["encoding"].as_str().unwrap().to_string(),
                ));
            }
        }
    }
    found.into_iter().map(Option::unwrap).collect()
}

/// Subscribe to channel ids, subscription ids 1, 2, ... in order.
pub async fn subscribe(ws: &mut Ws, channel_ids: &[u64]) {
    let subs: Vec<_> = channel_ids
        .iter()
        .enumerate()
        .map(|(i, id)| serde_json::json!({"id": i as u32 + 1, "channelId": id}))
        .collect();
    let msg = serde_json::json!({"op": "subscribe", "subscriptions": subs});
    ws.send(Message::Text(msg.to_string().into())).await.unwrap();
}

/// The next message data frame: (subscription id, log time, payload).
pub async fn next_data(ws: &mut Ws) -> (u32, u64, Vec<u8>) {
    loop {
        let msg = next_message(ws).await;
        let Message::Binary(b) = msg else { continue };
        // opcode 1 = message data: u32 subscription id, u64 log time, payload (little-endian)
        if b.first() != Some(&1) {
            continue;
        }
        let sub = u32::from_le_bytes(b[1..5].try_into().unwrap());
        let t = u64::from_le_bytes(b[5..13].try_into().unwrap());
        return (sub, t, b[13..].to_vec());
    }
}

/// The boxes of an annotations message (LINE_LOOPs of 4 corners) in image coordinates.
pub fn boxes(a: &ImageAnnotations) -> Vec<Detection> {
    a.points
        .iter()
        .filter(|p| p.r#type == 2 && p.points.len() == 4)
        .map(|p| Detection {
            x: p.points[0].x as f32,
            y: p.points[0].y as f32,
            width: (p.points[2].x - p.points[0].x) as f32,
            height: (p.points[2].y - p.points[0].y) as f32,
            score: 0.0,
        })
        .collect()
}

/// The received image demosaiced, with the received boxes drawn on it, as a PNG.
pub fn write_picture(img: &RawImage, dets: &[Detection], path: &Path) {
    use mosaicd::image::Image;
    use mosaicd::isp::rgb_from_mosaic_u8;
    let cfa = img
        .encoding
        .trim_start_matches("bayer_")
        .trim_end_matches('8')
        .to_uppercase();
    let (w, h) = (img.width as usize, img.height as usize);
    let mosaic = Image::from_fn(w, h, |x, y| img.data[y * img.step as usize + x]);
    let mut rgb = rgb_from_mosaic_u8(
        mosaic.view(),
        cfa.parse().unwrap(),
        mosaicd::isp::DemosaicMethod::Bilinear,
    )
    .unwrap();
    mosaicd::eval::draw_boxes(&mut rgb, dets);
    let flat: Vec<u8> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .flat_map(|(x, y)| rgb.get(x, y))
        .collect();
    image::RgbImage::from_raw(w as u32, h as u32, flat)
        .unwrap()
        .save(path)
        .unwrap();
}
