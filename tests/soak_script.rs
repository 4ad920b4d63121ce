//! `scripts/soak.sh` (the long-run measurement of docs/daemon.md, "Soak") runs end to end: a zero
//! length soak starts the daemon with its generated config (live synthetic camera, detection,
//! publishing, a rotating recording), samples it, stops it with SIGTERM and prints the summary.

use std::process::Command;

#[test]
fn a_zero_length_soak_starts_samples_stops_and_summarises() {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new("bash")
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/soak.sh"))
        .env("MOSAICD", env!("CARGO_BIN_EXE_mosaicd"))
        .env("OUT", dir.path())
        .env("DURATION", "0")
        .env("FPS", "10")
        .env("WIDTH", "640")
        .env("HEIGHT", "480")
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{text}");
    assert!(text.contains("exit status 0"), "{text}");
    assert!(text.contains("resident memory: after warm-up"), "{text}");
    assert!(text.contains("(stopped by signal)"), "{text}");
    let samples = std::fs::read_to_string(dir.path().join("samples.csv")).unwrap();
    assert!(
        samples.starts_with("t_s,rss_kib,fds\n") && samples.lines().count() >= 2,
        "{samples}"
    );
    let cfg = std::fs::read_to_string(dir.path().join("soak.toml")).unwrap();
    assert!(
        cfg.contains("max_files = 3") && cfg.contains("live = true"),
        "{cfg}"
    );
}
