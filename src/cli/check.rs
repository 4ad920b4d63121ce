//! `mosaicd check --config FILE`: is this config one `mosaicd run` would start from?
//!
//! It opens nothing the daemon would open: no camera, no shared memory, no recording or metrics
//! file. It checks, each problem named by its key:
//! - the file parses, has no unknown key and every value is in range ([`Config::load`]);
//! - the detector model loads, and is of the kind `compute.detector` names: for `"hog"`
//!   (`compute.model`) a built-in name, `opencv-default` where its weights are present
//!   (`$MOSAICD_DATA`), or a file; for `"acf"` the ACF model file `compute.acf_model`; relative
//!   files resolve against the config file's directory, then `/usr/share/mosaicd/models`;
//! - every camera's input exists: a recording or raw files (`camera.path`), a sidecar, or a V4L2
//!   device node (looked at, not opened);
//! - the directory of `metrics.textfile` exists.
//!
//! It prints how relative paths were resolved and what would run. Exit status 0 when the config
//! is good, 1 with every problem found (the systemd units run it as `ExecStartPre=`, so a bad
//! config fails the start with these messages in the journal).

use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};

use mosaicd::config::{Config, SourceType};

/// Arguments of `mosaicd check`.
#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// The config file to check (as given to `mosaicd run --config`).
    #[arg(long, short)]
    config: PathBuf,
}

/// The problems of one config, each naming its key (empty: the config is good). Lines
/// describing what was resolved and what would run go to `info`.
pub fn problems(path: &Path, info: &mut Vec<String>) -> Vec<String> {
    let (cfg, resolved) = match Config::load_resolved(path) {
        Ok(c) => c,
        Err(e) => return vec![e.to_string()],
    };
    let mut bad = Vec::new();
    for r in &resolved {
        info.push(format!(
            "{} = {:?}: {}",
            r.key,
            r.given.display().to_string(),
            r.resolved.display()
        ));
    }
    if cfg.compute.detect {
        // the key of the configured detector's model
        let (key, model) = cfg.compute.model_key();
        match mosaicd::pipeline::load_detector(&cfg) {
            Ok(_) => info.push(format!(
                "{key}: {model} loads ({} detector)",
                cfg.compute.detector
            )),
            Err(e) => {
                let mut msg = e.to_string();
                if let Some(r) = resolved.iter().find(|r| r.key == key && !r.exists()) {
                    let tried: Vec<String> = r.tried.iter().map(|p| p.display().to_string()).collect();
                    msg += &format!(" (a relative model file is looked for in: {})", tried.join(", "));
                }
                bad.push(msg);
            }
        }
    }
    for (i, cam) in cfg.cameras.iter().enumerate() {
        let key = |k: &str| format!("camera[{i}].{k}");
        let shown = |p: &Path| format!("{:?}", p.display().to_string());
        match cam.source {
            SourceType::Mcap | SourceType::Files => {
                if let Some(p) = &cam.path {
                    let ok = if cam.source == SourceType::Mcap {
                        p.is_file()
                    } else {
                        p.exists()
                    };
                    if !ok {
                        bad.push(format!(
                            "config key `{}` = {}: no such file",
                            key("path"),
                            shown(p)
                        ));
                    }
                }
            }
            SourceType::V4l2 => {
                if let Some(d) = &cam.device {
                    match std::fs::metadata(d) {
                        Ok(m) if m.file_type().is_char_device() => {}
                        Ok(_) => bad.push(format!(
                            "config key `{}` = {}: not a character device",
                            key("device"),
                            shown(d)
                        )),
                        Err(e) => bad.push(format!(
                            "config key `{}` = {}: {e} (is the camera connected? `v4l2-ctl --list-devices` lists them)",
                            key("device"),
                            shown(d)
                        )),
                    }
                }
            }
            SourceType::Synthetic => {}
        }
        if let Some(s) = cam.sidecar.as_ref().filter(|s| !s.is_file()) {
            bad.push(format!(
                "config key `{}` = {}: no such file",
                key("sidecar"),
                shown(s)
            ));
        }
        info.push(format!("camera {:?}: source {}", cam.name, cam.source.name()));
    }
    if let Some(t) = &cfg.metrics.textfile {
        let dir = t
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        if !dir.is_dir() {
            bad.push(format!(
                "config key `metrics.textfile` = {:?}: the directory {} does not exist",
                t.display().to_string(),
                dir.display()
            ));
        }
    }
    if cfg.record.enabled && cfg.record.path.is_relative() {
        info.push(format!(
            "record.path = {:?}: relative to the working directory",
            cfg.record.path.display().to_string()
        ));
    }
    bad
}

/// Run `mosaicd check`.
pub fn run(a: CheckArgs) -> anyhow::Result<()> {
    let mut info = Vec::new();
    let bad = problems(&a.config, &mut info);
    for l in &info {
        println!("  {l}");
    }
    if !bad.is_empty() {
        anyhow::bail!(
            "config {} has {} problem(s):\n  {}",
            a.config.display(),
            bad.len(),
            bad.join("\n  ")
        );
    }
    println!("config {}: ok", a.config.display());
    Ok(())
}
