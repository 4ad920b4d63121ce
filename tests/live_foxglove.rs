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

mod live_client;

use std::path::Path;
use std::time::Duration;

use foxglove::messages::{ImageAnnotations, RawImage};
use foxglove::Decode;
use live_client::{
    boxes, channels, connect, live_config, next_data, spawn_daemon, subscribe, write_picture, Daemon,
};

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");
/// How many frames a client stops reading for: 40 images of 393 kB, 16 MB, more than the kernel
/// buffers (the server's send buffer grows to 4 MiB at most, the client's receive buffer is
/// 16 KiB) and the client's queue (`client_backlog = 16` messages, 6 MB of images) hold. The
/// reading client's queue holds about 5 frames (image, boxes, stats): it must not lose any.
const STALL_FRAMES: usize = 40;
/// The camera's frame interval (10 frames/s), ns.
const FRAME_NS: u64 = 100_000_000;

fn start_daemon(dir: &Path) -> Daemon {
    let photo = mosaicd::data::require("kodak/kodim12.png");
    let cfg = dir.join("live.toml");
    let text = live_config(
        "live",
        &photo,
        "stats_interval_ms = 200\n",
        "client_backlog = 16\n",
    );
    std::fs::write(&cfg, text).unwrap();
    spawn_daemon(Path::new(BIN), &cfg)
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
