//! `systemd-analyze verify` passes on the shipped units.
//!
//! verify insists that ExecStart names an existing executable, so the units are copied to a
//! temporary directory with `/usr/local/bin/mosaicd` replaced by the binary cargo just built; the
//! template is verified through an instance name. The test fails (does not skip) when
//! `systemd-analyze` is missing: it is part of the CI image.

use std::path::Path;
use std::process::Command;

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
        std::fs::write(dir.path().join(unit), text.replace("/usr/local/bin/mosaicd", bin)).unwrap();
    }
    verify(dir.path(), "mosaicd.service");
    verify(dir.path(), "mosaicd@front.service");
}

#[test]
fn sysusers_snippet_puts_the_user_in_video() {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("systemd/mosaicd.sysusers.conf"))
            .unwrap();
    assert!(text.lines().any(|l| l.starts_with("u mosaicd ")));
    assert!(text.lines().any(|l| l.trim() == "m mosaicd video"));
}
