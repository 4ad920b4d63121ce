//! `mosaicd listen`: a subscriber in its own process that prints what a daemon publishes as JSON
//! lines (one object per sample, with a `"topic"` key).
//!
//! It opens (or creates, if it starts first) the camera's `detections` and `stats` services — and
//! `gradients` with `--gradients`, `keypoints` with `--keypoints`, `descriptors` with
//! `--descriptors` — with the same settings as the
//! daemon. It stops after `--count`
//! detections, after the daemon's final stats with `--until-final`, after `--timeout-s`, or on
//! SIGINT/SIGTERM. Other signals iceoryx2 catches (SIGCONT when a listener stopped with SIGSTOP
//! is continued, SIGTSTP, SIGUSR1, ...) do not stop it. A daemon keeps its publishers after its final stats until its subscribers are gone
//! (bounded, `pipeline::sinks::iceoryx::FINAL_LINGER`), so a listener subscribed while it ran gets
//! every message up to the final stats even if it polled only after the last frame.

use std::io::Write;
use std::time::{Duration, Instant};

use serde_json::json;

use iceoryx2::node::NodeWaitFailure;

use mosaicd::config::Iox2Root;
use mosaicd::publish::messages::{DescriptorsMsg, DetectionsMsg, KeypointsMsg};
use mosaicd::publish::{
    create_node, descriptors_service, detections_service, gradients_service, keypoints_service, root_dir,
    stats_service, subscriber,
};

/// Poll period of the subscriber loop.
const CYCLE: Duration = Duration::from_millis(1);

/// Arguments of `mosaicd listen`.
#[derive(clap::Args, Debug)]
pub struct ListenArgs {
    /// Camera name (as in the daemon's config).
    #[arg(long)]
    camera: String,
    /// Service name prefix (`publish.service_prefix`).
    #[arg(long, default_value = "mosaicd")]
    prefix: String,
    /// The daemon's iceoryx2 root (`publish.root`): `auto` (the default) resolves as the daemon's
    /// `"auto"` does for the same user, or a directory.
    #[arg(long, default_value = mosaicd::config::AUTO_ROOT)]
    root: std::path::PathBuf,
    /// Samples buffered per service (must not exceed the daemon's `publish.subscriber_buffer`).
    #[arg(long, default_value_t = 64)]
    buffer: usize,
    /// Exit after this many detections messages.
    #[arg(long)]
    count: Option<u64>,
    /// Exit after the daemon's final stats message.
    #[arg(long)]
    until_final: bool,
    /// Exit after this many seconds.
    #[arg(long)]
    timeout_s: Option<f64>,
    /// Also print the gradients service (header and payload size).
    #[arg(long)]
    gradients: bool,
    /// Also print the keypoints service (daemon with `compute.keypoints = true`).
    #[arg(long)]
    keypoints: bool,
    /// Also print the descriptors service (daemon with `compute.keypoint_descriptors = true`;
    /// base64, one per keypoint of the keypoints message with the same index).
    #[arg(long)]
    descriptors: bool,
}

fn keypoints_json(m: &KeypointsMsg) -> serde_json::Value {
    json!({
        "topic": "keypoints",
        "index": m.index,
        "sequence": m.sequence,
        "capture_timestamp_ns": m.capture_timestamp_ns,
        "publish_timestamp_ns": m.publish_timestamp_ns,
        "frame_width": m.frame_width,
        "frame_height": m.frame_height,
        "keypoint_count": m.keypoint_count,
        "overflow": m.overflow,
        "keypoints": m.keypoints(),
    })
}

fn descriptors_json(m: &DescriptorsMsg) -> serde_json::Value {
    json!({
        "topic": "descriptors",
        "index": m.index,
        "sequence": m.sequence,
        "capture_timestamp_ns": m.capture_timestamp_ns,
        "descriptor_count": m.descriptor_count,
        "overflow": m.overflow,
        "descriptors": mosaicd::pipeline::descriptors_json(m.descriptors()),
    })
}

fn detections_json(m: &DetectionsMsg) -> serde_json::Value {
    json!({
        "topic": "detections",
        "index": m.index,
        "sequence": m.sequence,
        "sensor_sequence": if m.sensor_sequence == u64::MAX { None } else { Some(m.sensor_sequence) },
        "capture_timestamp_ns": m.capture_timestamp_ns,
        "publish_timestamp_ns": m.publish_timestamp_ns,
        "latency_ns": m.latency_ns,
        "frame_width": m.frame_width,
        "frame_height": m.frame_height,
        "box_count": m.box_count,
        "overflow": m.overflow,
        "mean_magnitude": m.mean_magnitude,
        "boxes": m.boxes(),
    })
}

/// The services `args` subscribe to, in the order they are opened.
fn subscribed_services(args: &ListenArgs) -> Vec<&'static str> {
    let mut v = vec!["detections", "stats"];
    for (on, name) in [
        (args.gradients, "gradients"),
        (args.keypoints, "keypoints"),
        (args.descriptors, "descriptors"),
    ] {
        if on {
            v.push(name);
        }
    }
    v
}

/// Run `mosaicd listen`.
pub fn run(args: ListenArgs) -> anyhow::Result<()> {
    let services = subscribed_services(&args).join(",");
    let root = root_dir(&Iox2Root::from(args.root))?;
    let node = create_node(&format!("mosaicd-listen-{}", std::process::id()), false, &root)?;
    let det = detections_service(&node, &args.prefix, &args.camera, args.buffer)?;
    let st = stats_service(&node, &args.prefix, &args.camera, args.buffer)?;
    let det_sub = subscriber(&det, args.buffer, "detections")?;
    let st_sub = subscriber(&st, args.buffer, "stats")?;
    let grad = if args.gradients {
        let svc = gradients_service(&node, &args.prefix, &args.camera, args.buffer)?;
        let sub = svc
            .subscriber_builder()
            .buffer_size(args.buffer)
            .create()
            .map_err(|e| anyhow::anyhow!("gradients subscriber: {e}"))?;
        Some((svc, sub))
    } else {
        None
    };
    let kp_sub = if args.keypoints {
        let svc = keypoints_service(&node, &args.prefix, &args.camera, args.buffer)?;
        Some(subscriber(&svc, args.buffer, "keypoints")?)
    } else {
        None
    };
    let desc_sub = if args.descriptors {
        let svc = descriptors_service(&node, &args.prefix, &args.camera, args.buffer)?;
        Some(subscriber(&svc, args.buffer, "descriptors")?)
    } else {
        None
    };
    eprintln!(
        "mosaicd listen: subscribed to {}/{}/{{{}}} under {}",
        args.prefix,
        args.camera,
        services,
        root.display()
    );
    let start = Instant::now();
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let mut received = 0u64;
    let mut finished = false;
    // Keypoints are published before the frame's detections, so draining them first keeps a
    // frame's lines together.
    let drain_detections = |out: &mut std::io::StdoutLock<'_>, received: &mut u64| -> anyhow::Result<()> {
        if let Some(sub) = &kp_sub {
            while let Some(s) = sub.receive()? {
                writeln!(out, "{}", keypoints_json(&s))?;
            }
        }
        if let Some(sub) = &desc_sub {
            while let Some(s) = sub.receive()? {
                writeln!(out, "{}", descriptors_json(&s))?;
            }
        }
        while let Some(s) = det_sub.receive()? {
            writeln!(out, "{}", detections_json(&s))?;
            *received += 1;
        }
        Ok(())
    };
    loop {
        match node.wait(CYCLE) {
            Ok(()) => {}
            Err(NodeWaitFailure::TerminationRequest) => break,
            // iceoryx2 catches every non-fatal signal, and any of them (SIGCONT when a stopped
            // listener goes on, SIGTSTP, SIGUSR1, ...) cuts the sleep short with the same error as
            // SIGINT. Only SIGINT and SIGTERM stop the listener: a wait of zero says which it was.
            Err(_) => {
                if node.wait(Duration::ZERO).is_err() {
                    break;
                }
            }
        }
        drain_detections(&mut out, &mut received)?;
        if let Some((_, sub)) = &grad {
            while let Some(s) = sub.receive()? {
                let mut v = serde_json::to_value(s.user_header())?;
                v["topic"] = json!("gradients");
                v["payload_bytes"] = json!(s.payload().len());
                writeln!(out, "{v}")?;
            }
        }
        while let Some(s) = st_sub.receive()? {
            let mut v = serde_json::to_value(*s)?;
            v["topic"] = json!("stats");
            writeln!(out, "{v}")?;
            if s.is_final != 0 {
                finished = true;
            }
        }
        out.flush()?;
        if finished && args.until_final {
            // Everything the daemon published went out before its final stats.
            drain_detections(&mut out, &mut received)?;
            break;
        }
        if args.count.is_some_and(|c| received >= c) {
            break;
        }
        if args.timeout_s.is_some_and(|t| start.elapsed().as_secs_f64() >= t) {
            out.flush()?;
            anyhow::bail!(
                "timed out after {:?} s with {received} detections messages",
                args.timeout_s.unwrap_or(0.0)
            );
        }
    }
    out.flush()?;
    Ok(())
}
