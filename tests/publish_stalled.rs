//! A subscriber that stops reading never blocks the daemon: with a subscriber buffer of 2 and a
//! subscriber in this process that never calls `receive`, a daemon process publishes 200 frames and
//! exits normally (safe overflow overwrites the stalled subscriber's oldest samples).
//! (Throughput with and without a stalled subscriber is a benchmark: `mosaicd bench pipeline`.)

use std::process::Command;

use mosaicd::publish::{create_node, detections_service, subscriber};

#[test]
fn a_stalled_subscriber_does_not_block_publishing() {
    let (prefix, camera) = (format!("st{}", std::process::id()), "stall".to_string());
    let node = create_node(
        &format!("stalltest{}", std::process::id()),
        false,
        &mosaicd::publish::root_dir(&mosaicd::config::Iox2Root::Auto).unwrap(),
    )
    .unwrap();
    let svc = detections_service(&node, &prefix, &camera, 2).unwrap();
    let sub = subscriber(&svc, 2, "stalled").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    std::fs::write(
        &cfg,
        format!(
            "[publish]\nservice_prefix = \"{prefix}\"\nsubscriber_buffer = 2\n[compute]\ndetect = false\n\
             [[camera]]\nname = \"{camera}\"\nsource = \"synthetic\"\nwidth = 64\nheight = 48\nframes = 200\n"
        ),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(["run", "--config"])
        .arg(&cfg)
        .env("RUST_LOG", "warn")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("200 frames processed"));
    // The stalled subscriber is still connected and intact (reading now must not fail; what it
    // still holds once the publisher is gone is up to iceoryx2's reclaim policy).
    assert!(sub.receive().is_ok());
}
