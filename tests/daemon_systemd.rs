//! `systemd-analyze verify` passes on the shipped units, and `systemd-analyze security
//! --offline=yes` rates both at an exposure of at most [`MAX_EXPOSURE`].
//!
//! verify insists that ExecStart names an existing executable, so the units are copied to a
//! temporary directory with `/usr/bin/mosaicd` replaced by the binary cargo just built; the
//! template is checked through an instance name. The tests fail (do not skip) when
//! `systemd-analyze` is missing: it is part of the CI image (scripts/setup.sh installs systemd).

use std::path::Path;
use std::process::Command;

/// The highest exposure score (0 = safest, 10 = unprotected) the units may have.
const MAX_EXPOSURE: f64 = 2.0;

/// The shipped units, copied to `dir` with ExecStart pointing at the built binary.
fn install(dir: &Path) {
    let bin = env!("CARGO_BIN_EXE_mosaicd");
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("systemd");
    for unit in ["mosaicd.service", "mosaicd@.service"] {
        let text = std::fs::read_to_string(src.join(unit)).unwrap();
        std::fs::write(dir.join(unit), text.replace("/usr/bin/mosaicd", bin)).unwrap();
    }
}

/// The overall exposure `systemd-analyze security --offline=yes` gives `unit`.
fn exposure(dir: &Path, unit: &str) -> f64 {
    let out = Command::new("systemd-analyze")
        .args(["security", "--offline=yes", "--no-pager"])
        .arg(dir.join(unit))
        .current_dir(dir)
        .output()
        .expect("systemd-analyze must be installed (apt-get install systemd)");
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find(|l| l.contains("Overall exposure level"))
        .unwrap_or_else(|| {
            panic!(
                "{unit}: no overall exposure in: {text}{}",
                String::from_utf8_lossy(&out.stderr)
            )
        });
    // "→ Overall exposure level for mosaicd.service: 0.6 SAFE 😀"
    line.rsplit(": ")
        .next()
        .and_then(|t| t.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{unit}: cannot read the score in {line:?}"))
}

fn verify(dir: &Path, unit: &str) {
    let out = Command::new("systemd-analyze")
        .arg("verify")
        .arg(dir.join(unit))
        .current_dir(dir)
        .output()
        .expect("systemd-analyze must be installed (apt-get install systemd)");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{unit}: {stderr}");
    assert!(stderr.trim().is_empty(), "{unit}: warnings: {stderr}");
}

#[test]
fn units_verify() {
    let bin = env!("CARGO_BIN_EXE_mosaicd");
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("systemd");
    let dir = tempfile::tempdir().unwrap();
    for unit in ["mosaicd.service", "mosaicd@.service"] {
        let text = std::fs::read_to_string(src.join(unit)).unwrap();
        assert!(
            text.contains("Type=notify") && text.contains("WatchdogSec=") && text.contains("RemoveIPC=no")
        );
        assert!(text.contains("DeviceAllow=char-video4linux rw") && text.contains("ProtectSystem=strict"));
        assert!(
            text.contains("ExecReload=/bin/kill -HUP $MAINPID"),
            "{unit}: reload sends SIGHUP"
        );
        // The config is checked before anything is opened, with the same file as the run.
        let pre = text.lines().find(|l| l.starts_with("ExecStartPre=")).unwrap();
        let start = text.lines().find(|l| l.starts_with("ExecStart=")).unwrap();
        assert_eq!(
            pre.replace("ExecStartPre=", "").replace(" check ", " run "),
            start.replace("ExecStart=", ""),
            "{unit}"
        );
        // iceoryx2 lives in the runtime directory (publish.root's default), not in /tmp.
        assert!(
            text.contains("RuntimeDirectory=mosaicd\n") && text.contains("PrivateTmp=yes"),
            "{unit}"
        );
        let rw = text.lines().find(|l| l.starts_with("ReadWritePaths=")).unwrap();
        assert!(
            !rw.split_whitespace().any(|p| p.ends_with("/tmp")),
            "{unit}: {rw}"
        );
        assert!(
            text.contains("UMask=0027") && text.contains("PrivateNetwork=yes"),
            "{unit}"
        );
        std::fs::write(dir.path().join(unit), text.replace("/usr/bin/mosaicd", bin)).unwrap();
    }
    verify(dir.path(), "mosaicd.service");
    verify(dir.path(), "mosaicd@front.service");
}

#[test]
fn units_are_hardened_to_an_exposure_of_at_most_2() {
    let dir = tempfile::tempdir().unwrap();
    install(dir.path());
    for unit in ["mosaicd.service", "mosaicd@front.service"] {
        let score = exposure(dir.path(), unit);
        eprintln!("{unit}: exposure {score}");
        assert!(score <= MAX_EXPOSURE, "{unit}: exposure {score} > {MAX_EXPOSURE}");
    }
}

#[test]
fn sysusers_snippet_puts_the_user_in_video() {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("systemd/mosaicd.sysusers"))
            .unwrap();
    assert!(text.lines().any(|l| l.starts_with("u mosaicd ")));
    assert!(text.lines().any(|l| l.trim() == "m mosaicd video"));
}

/// The live view's drop-in (systemd/live-view.conf.example, installed as
/// `<unit>.d/live-view.conf`) verifies, opens IPv4/IPv6 sockets to loopback only, and keeps the
/// unit within [`MAX_EXPOSURE`].
#[test]
fn the_live_view_drop_in_allows_loopback_tcp_and_stays_hardened() {
    let dir = tempfile::tempdir().unwrap();
    install(dir.path());
    let drop_in = Path::new(env!("CARGO_MANIFEST_DIR")).join("systemd/live-view.conf.example");
    let text = std::fs::read_to_string(&drop_in).unwrap();
    assert!(text.contains("RestrictAddressFamilies=AF_UNIX AF_INET AF_INET6"));
    assert!(text.contains("IPAddressAllow=localhost") && !text.contains("\nIPAddressDeny="));
    let without = exposure(dir.path(), "mosaicd.service");
    let d = dir.path().join("mosaicd.service.d");
    std::fs::create_dir(&d).unwrap();
    std::fs::copy(&drop_in, d.join("live-view.conf")).unwrap();
    verify(dir.path(), "mosaicd.service");
    let score = exposure(dir.path(), "mosaicd.service");
    assert!(
        score > without,
        "the drop-in was not applied: exposure {score}, {without} without"
    );
    assert!(score <= MAX_EXPOSURE, "exposure {score} with the drop-in");
}
