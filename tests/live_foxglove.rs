//! The live view (`[foxglove] listen`) with a real WebSocket client: `mosaicd run` streams a photo
//! with people (Kodak kodim12 from the shared data, sampled to a mosaic, looped at 10 frames/s)
//! and this test connects to it over TCP as the Foxglove app does (subprotocol `foxglove.sdk.v1`,
//! the one the `foxglove` crate's server speaks), reads the channel advertisements, subscribes,
//! and checks that:
//!
//! - an image (`foxglove.RawImage`, `bayer_*8`, every 2x2 tile) and boxes
//!   (`foxglove.ImageAnnotations`) arrive for the same frame (same log time, same message
//!   timestamps), the boxes inside the image;
//! - while a client that subscribed stops reading, another receives every frame in order and only
//!   the stalled one loses frames; a client that disappears mid-stream without closing its
//!   connection does not stop the daemon either: a client connecting after them still receives
//!   new frames, and the daemon stops cleanly on SIGTERM, logging what it published;
//! - the stats channel carries the live view's counters.
//!
//! With `MOSAICD_LIVE_PNG=FILE`, the test also writes the received image, demosaiced, with the
//! received boxes drawn on it (`docs/daemon.md`, "Live view in Foxglove", names the command).

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use foxglove::messages::{ImageAnnotations, RawImage};
use foxglove::Decode;
use futures_util::{SinkExt, StreamExt};
use mosaicd::geometry::Detection;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::tungstenite::Message;

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");
/// How long any one step may take (a debug build detects a 768x512 frame in well under this).
const STEP: Duration = Duration::from_secs(60);
/// How many frames a client stops reading for: 40 images of 393 kB, 16 MB, more than the kernel
/// buffers (the server's send buffer grows to 4 MiB at most, the client's receive buffer is
/// 16 KiB) and the client's queue (`client_backlog = 16` messages, 6 MB of images) hold. The
/// reading client's queue holds about 5 frames (image, boxes, stats): it must not lose any.
const STALL_FRAMES: usize = 40;
/// The camera's frame interval (10 frames/s), ns.
const FRAME_NS: u64 = 100_000_000;

/// A daemon with the live view on a free port; killed when dropped.
struct Daemon {
    child: Child,
    url: String,
    log: mpsc::Receiver<String>,
}

impl Drop for Daemon {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start_daemon(dir: &Path) -> Daemon {
    let photo = mosaicd::data::require("kodak/kodim12.png");
    let cfg = dir.join("live.toml");
    std::fs::write(
        &cfg,
        format!(
            r#"[daemon]
threads = 2
stats_interval_ms = 200
[publish]
enabled = false
[foxglove]
listen = "127.0.0.1:0"
preview_decimation = 1
client_backlog = 16
[[camera]]
name = "live"
source = "files"
path = {photo:?}
fps = 10.0
realtime = true
loop = true
"#
        ),
    )
    .unwrap();
    let mut child = Command::new(BIN)
        .args(["run", "--config"])
        .arg(&cfg)
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

type Ws = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// Connect as the Foxglove app does: the SDK's subprotocol in the handshake. `recv_buffer`: a
/// small receive buffer (bytes), so that a client that stops reading fills its socket quickly.
async fn connect(url: &str, recv_buffer: Option<u32>) -> Ws {
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
async fn next_message(ws: &mut Ws) -> Message {
    let msg = tokio::time::timeout(STEP, ws.next()).await;
    msg.expect("a message in time")
        .expect("the connection is open")
        .unwrap()
}

/// Read the advertisements until `topics` are all there; their channel ids, in order.
async fn channels(ws: &mut Ws, topics: &[&str]) -> Vec<(u64, String, String)> {
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
async fn subscribe(ws: &mut Ws, channel_ids: &[u64]) {
    let subs: Vec<_> = channel_ids
        .iter()
        .enumerate()
        .map(|(i, id)| serde_json::json!({"id": i as u32 + 1, "channelId": id}))
        .collect();
    let msg = serde_json::json!({"op": "subscribe", "subscriptions": subs});
    ws.send(Message::Text(msg.to_string().into())).await.unwrap();
}

/// The next message data frame: (subscription id, log time, payload).
async fn next_data(ws: &mut Ws) -> (u32, u64, Vec<u8>) {
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
fn boxes(a: &ImageAnnotations) -> Vec<Detection> {
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
fn write_picture(img: &RawImage, dets: &[Detection], path: &Path) {
    use mosaicd::image::Image;
    use mosaicd::isp::demosaic::rgb_from_mosaic_u8;
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
    mosaicd::eval::draw::draw_boxes(&mut rgb, dets);
    let flat: Vec<u8> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .flat_map(|(x, y)| rgb.get(x, y))
        .collect();
    image::RgbImage::from_raw(w as u32, h as u32, flat)
        .unwrap()
        .save(path)
        .unwrap();
}

#[test]
fn a_foxglove_client_receives_image_and_boxes_of_one_frame_and_clients_that_stall_or_vanish_do_not_stop_the_daemon(
) {
    let dir = tempfile::tempdir().unwrap();
    let mut daemon = start_daemon(dir.path());
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        // 1. Image and boxes of the same frame.
        let mut ws = connect(&daemon.url, None).await;
        let ch = channels(&mut ws, &["/live/preview", "/live/annotations", "/live/stats"]).await;
        assert_eq!(
            (ch[0].1.as_str(), ch[0].2.as_str()),
            ("foxglove.RawImage", "protobuf")
        );
        assert_eq!(
            (ch[1].1.as_str(), ch[1].2.as_str()),
            ("foxglove.ImageAnnotations", "protobuf")
        );
        assert_eq!((ch[2].1.as_str(), ch[2].2.as_str()), ("mosaicd.Stats", "json"));
        subscribe(&mut ws, &[ch[0].0, ch[1].0, ch[2].0]).await;
        let mut images = std::collections::BTreeMap::new();
        let mut annotations = std::collections::BTreeMap::new();
        let mut live_stats = None;
        let (t, img, ann) = loop {
            let (sub, t, payload) = next_data(&mut ws).await;
            match sub {
                1 => {
                    images.insert(t, RawImage::decode(payload.as_slice()).unwrap());
                }
                2 => {
                    annotations.insert(t, ImageAnnotations::decode(payload.as_slice()).unwrap());
                }
                3 => live_stats = Some(serde_json::from_slice::<serde_json::Value>(&payload).unwrap()),
                s => panic!("unknown subscription {s}"),
            }
            let both = images
                .keys()
                .find(|t| annotations.get(t).is_some_and(|a| !boxes(a).is_empty()))
                .copied();
            if let (Some(t), Some(_)) = (both, &live_stats) {
                break (t, images.remove(&t).unwrap(), annotations.remove(&t).unwrap());
            }
        };
        // kodim12 is 768x512, the preview keeps every 2x2 tile (preview_decimation = 1).
        assert_eq!((img.width, img.height, img.step), (768, 512, 768));
        assert!(
            img.encoding.starts_with("bayer_") && img.encoding.ends_with('8'),
            "{}",
            img.encoding
        );
        assert_eq!(img.frame_id, "live");
        assert_eq!(img.data.len(), 768 * 512);
        let ts = img.timestamp.unwrap();
        assert_eq!(ts.total_nanos(), t, "image timestamp = log time");
        let dets = boxes(&ann);
        for (p, d) in ann.points.iter().zip(&dets) {
            assert_eq!(
                p.timestamp.unwrap().total_nanos(),
                t,
                "boxes carry the image's timestamp"
            );
            assert!(
                d.x >= -1.0 && d.y >= -1.0 && d.x + d.width <= 769.0 && d.y + d.height <= 513.0,
                "box {d:?} outside the 768x512 image"
            );
        }
        assert_eq!(ann.texts.len(), dets.len(), "a score per box");
        assert!(ann.metadata.iter().any(|kv| kv.key == "sequence"));
        let live = &live_stats.unwrap()["live"];
        assert!(live["clients"].as_u64().unwrap() >= 1, "{live}");
        assert!(live["subscriptions"].as_u64().unwrap() >= 3, "{live}");
        if let Some(p) = std::env::var_os("MOSAICD_LIVE_PNG") {
            write_picture(&img, &dets, Path::new(&p));
        }

        // 2. A client that subscribes to the images and stops reading (a small receive buffer,
        // so its socket fills within a second or two): while it stalls, the first client still
        // receives every frame, in order; the stalled one, when it reads again, finds frames
        // missing: it alone lost them.
        let mut stalled = connect(&daemon.url, Some(16 * 1024)).await;
        let sch = channels(&mut stalled, &["/live/preview"]).await;
        subscribe(&mut stalled, &[sch[0].0]).await;
        let mut sequences = Vec::new();
        let mut last_t = 0;
        while sequences.len() < STALL_FRAMES {
            let (sub, t, payload) = next_data(&mut ws).await;
            if sub == 2 {
                let a = ImageAnnotations::decode(payload.as_slice()).unwrap();
                let seq = a.metadata.iter().find(|kv| kv.key == "sequence").unwrap();
                sequences.push(seq.value.parse::<u64>().unwrap());
                last_t = t;
            }
        }
        assert!(
            sequences.windows(2).all(|w| w[1] == w[0] + 1),
            "the reading client missed frames while another stalled: {sequences:?}"
        );
        let mut stalled_times = Vec::new();
        while stalled_times.last().is_none_or(|&t| t < last_t) {
            let (_, t, _) = next_data(&mut stalled).await;
            stalled_times.push(t);
        }
        let lost = stalled_times
            .windows(2)
            .map(|w| ((w[1] - w[0]) / FRAME_NS).saturating_sub(1))
            .sum::<u64>();
        assert!(lost > 0, "the stalled client lost nothing: {stalled_times:?}");
        eprintln!(
            "while one client stalled: the reading client received {STALL_FRAMES} frames in order, \
             the stalled one lost {lost} of its images"
        );

        // The first client vanishes mid-stream (its socket closed with no close handshake).
        let (_, seen_before, _) = next_data(&mut ws).await;
        drop(ws);
        tokio::time::sleep(Duration::from_millis(1500)).await;

        // 3. The daemon goes on: a new client receives newer frames.
        let mut late = connect(&daemon.url, None).await;
        let lch = channels(&mut late, &["/live/annotations"]).await;
        subscribe(&mut late, &[lch[0].0]).await;
        let mut newer = 0;
        while newer < 3 {
            let (_, t, payload) = next_data(&mut late).await;
            ImageAnnotations::decode(payload.as_slice()).unwrap();
            if t > seen_before {
                newer += 1;
            }
        }
        drop(stalled);
        drop(late);
    });

    // 4. SIGTERM: a clean stop, with the live view's account in the log.
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(daemon.child.id() as i32, libc::SIGTERM) };
    let status = daemon.child.wait().unwrap();
    // (the reader thread ends at the pipe's end, after the exit)
    let log: Vec<String> = daemon.log.iter().collect();
    assert!(status.success(), "{status}: {}", log.join("\n"));
    let end = log
        .iter()
        .find(|l| l.contains("live view finished"))
        .unwrap_or_else(|| panic!("no live view summary in\n{}", log.join("\n")));
    assert!(end.contains("clients_total=3"), "{end}");
}
