//! Relative paths in a config file resolve against the config file's directory (models also
//! against /usr/share/mosaicd/models), never the working directory; `mosaicd check` validates a
//! config without opening anything and exits 0 or 1 with messages that name the key.
//!
//! Every command here runs from another directory than the config's (`/`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

fn mosaicd(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(args)
        .current_dir("/")
        .output()
        .expect("run mosaicd")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A config directory holding a model file and a recording beside the config, which names both
/// by relative paths; `extra` is added to the file.
fn config_dir(extra: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("rec")).unwrap();
    std::fs::copy(repo("models/mosaic.json"), dir.path().join("mine.json")).unwrap();
    std::fs::copy(
        repo("recordings/synthetic_pan.mcap"),
        dir.path().join("rec/pan.mcap"),
    )
    .unwrap();
    let cfg = dir.path().join("mosaicd.toml");
    std::fs::write(
        &cfg,
        format!(
            "[publish]\nenabled = false\n[compute]\nmodel = \"mine.json\"\n{extra}\n\
             [[camera]]\nname = \"pan\"\nsource = \"mcap\"\npath = \"rec/pan.mcap\"\n"
        ),
    )
    .unwrap();
    (dir, cfg)
}

/// `mosaicd check` on [`config_dir`]`(extra)` exits 1 and its messages contain every `want`.
fn check_fails_naming(extra: &str, want: &[&str]) {
    let (_dir, cfg) = config_dir(extra);
    let o = mosaicd(&["check", "--config", cfg.to_str().unwrap()]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{extra}: {t}");
    for w in want {
        assert!(t.contains(w), "{extra}: {w:?} not in {t}");
    }
}

#[test]
fn relative_model_and_recording_resolve_against_the_config_dir_from_any_cwd() {
    let (dir, cfg) = config_dir("");
    let c = cfg.to_str().unwrap();
    let o = mosaicd(&["check", "--config", c]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains(&format!("{}", dir.path().join("mine.json").display())),
        "{t}"
    );
    assert!(
        t.contains(&format!("{}", dir.path().join("rec/pan.mcap").display())),
        "{t}"
    );
    assert!(t.contains("ok"), "{t}");
    let o = mosaicd(&["run", "--config", c]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("12 frames processed of 12 captured"), "{t}");
}

#[test]
fn check_exits_1_naming_the_key_of_every_problem() {
    let cases: [(&str, &[&str]); 4] = [
        ("[daemon]\nthreads = 0\n", &["daemon.threads", "1..=256"]),
        ("[daemon]\nthreadz = 2\n", &["threadz"]),
        (
            "[metrics]\ntextfile = \"/nonexistent-dir/mosaicd.prom\"\n",
            &["metrics.textfile", "/nonexistent-dir"],
        ),
        (
            "[metrics]\ntextfile = \"/tmp/mosaicd.txt\"\n",
            &["metrics.textfile", ".prom"],
        ),
    ];
    for (extra, want) in cases {
        check_fails_naming(extra, want);
    }
    // A model found nowhere: the places looked at are named; so is the missing recording.
    let (dir, cfg) = config_dir("");
    std::fs::remove_file(dir.path().join("mine.json")).unwrap();
    std::fs::remove_file(dir.path().join("rec/pan.mcap")).unwrap();
    let o = mosaicd(&["check", "--config", cfg.to_str().unwrap()]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(t.contains("2 problem(s)"), "{t}");
    assert!(t.contains("compute.model"), "{t}");
    assert!(t.contains("/usr/share/mosaicd/models/mine.json"), "{t}");
    assert!(t.contains("camera[0].path"), "{t}");
}

#[test]
fn check_names_the_key_the_value_and_the_allowed_values_of_a_refused_typed_value() {
    // Typed keys are parsed when the file is read; the message is the range errors' own, with
    // the camera's index, not the TOML parser's.
    let (_dir, cfg) = config_dir("[[camera]]\nname = \"two\"\nsource = \"synthetic\"\ncfa = \"RGBW\"\n");
    let o = mosaicd(&["check", "--config", cfg.to_str().unwrap()]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(
        t.contains(
            "\n  config key `camera[0].cfa` = \"RGBW\" is out of range: allowed one of RGGB, BGGR, GRBG, GBRG\n"
        ),
        "{t}"
    );
    assert!(!t.contains("TOML parse error"), "{t}");
    let cases: [(&str, &str); 3] = [
        (
            "svm = \"int8\"",
            "config key `compute.svm` = \"int8\" is out of range: allowed one of \"f32\", \"i8\", \"auto\"",
        ),
        (
            "wb_gains = \"warm\"",
            "config key `compute.wb_gains` = \"warm\" is out of range: allowed \"auto\", \"file\", \"grey-world\", \"none\" or \"R,G,B\" (each finite, > 0 and < 16)",
        ),
        (
            "mosaic_tone = \"gamma\"",
            "config key `compute.mosaic_tone` = \"gamma\" is out of range: allowed one of \"model\", \"linear\", \"srgb\"",
        ),
    ];
    for (extra, want) in cases {
        check_fails_naming(extra, &[want]);
    }
}

#[test]
fn check_opens_no_camera_and_no_shared_memory() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("iox");
    let cfg = dir.path().join("cam.toml");
    let write = |device: &str| {
        std::fs::write(
            &cfg,
            format!(
                "[publish]\nroot = {root:?}\n[[camera]]\nname = \"front\"\nsource = \"v4l2\"\ndevice = {device:?}\n"
            ),
        )
        .unwrap()
    };
    // A character device that is no camera: check looks at it and does not open it.
    write("/dev/null");
    let o = mosaicd(&["check", "--config", cfg.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!root.exists(), "check created the iceoryx2 root");
    write("/dev/no-such-video");
    let o = mosaicd(&["check", "--config", cfg.to_str().unwrap()]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(
        t.contains("camera[0].device") && t.contains("/dev/no-such-video"),
        "{t}"
    );
    write("/tmp");
    let t = text(&mosaicd(&["check", "--config", cfg.to_str().unwrap()]));
    assert!(t.contains("not a character device"), "{t}");
}

#[test]
fn the_installed_template_checks_once_its_camera_exists() {
    // config/system.toml is /etc/mosaicd/mosaicd.toml in the Debian package; here its device is
    // replaced by a character device that exists.
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("mosaicd.toml");
    let text_in = std::fs::read_to_string(repo("config/system.toml")).unwrap();
    assert!(text_in.contains("device = \"/dev/video0\""));
    std::fs::write(&cfg, text_in.replace("/dev/video0", "/dev/null")).unwrap();
    let o = mosaicd(&["check", "--config", cfg.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn opencv_default_needs_mosaicd_data_and_no_path_is_compiled_in() {
    let (_dir, cfg) = config_dir("");
    let t = std::fs::read_to_string(&cfg)
        .unwrap()
        .replace("\"mine.json\"", "\"opencv-default\"");
    std::fs::write(&cfg, t).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(["check", "--config", cfg.to_str().unwrap()])
        .current_dir("/")
        .env_remove(mosaicd::data::DATA_ENV)
        .output()
        .unwrap();
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(
        t.contains("compute.model") && t.contains("MOSAICD_DATA is not set"),
        "{t}"
    );
    // The binary holds no path to a checkout's shared data.
    let bin = std::fs::read(env!("CARGO_BIN_EXE_mosaicd")).unwrap();
    let needle = b"shared/data";
    assert!(
        !bin.windows(needle.len()).any(|w| w == needle),
        "the binary contains \"shared/data\""
    );
}

#[test]
fn check_validates_the_acf_detector_and_its_model_file() {
    // compute.detector = "acf" reads compute.acf_model, resolved like compute.model.
    let (dir, cfg) = config_dir("detector = \"acf\"\nacf_model = \"acf.json\"\nhit_threshold = 20.0");
    std::fs::copy(repo("models/acf-mosaic.json"), dir.path().join("acf.json")).unwrap();
    let c = cfg.to_str().unwrap();
    let o = mosaicd(&["check", "--config", c]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("compute.acf_model") && t.contains("(acf detector)"),
        "{t}"
    );
    assert!(
        t.contains(&format!("{}", dir.path().join("acf.json").display())),
        "{t}"
    );
    let o = mosaicd(&["run", "--config", c]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("12 frames processed of 12 captured"), "{t}");
    // Each problem names its key: a bad detector, a model of the other kind, a missing file.
    let cases: [(&str, &[&str]); 4] = [
        ("detector = \"ACF\"", &["compute.detector", "\"hog\", \"acf\""]),
        (
            "detector = \"acf\"\nacf_model = \"mine.json\"",
            &["compute.acf_model", "is a HOG model, not an ACF model"],
        ),
        (
            "detector = \"acf\"\nacf_model = \"none.json\"",
            &["compute.acf_model", "/usr/share/mosaicd/models/none.json"],
        ),
        (
            "detector = \"acf\"\nhit_threshold = 150.0",
            &["compute.hit_threshold", "-100..=100"],
        ),
    ];
    for (extra, want) in cases {
        check_fails_naming(extra, want);
    }
    // The HOG detector's model key holding an ACF file is refused too.
    let (dir, cfg) = config_dir("");
    std::fs::copy(repo("models/acf-mosaic.json"), dir.path().join("mine.json")).unwrap();
    let t = text(&mosaicd(&["check", "--config", cfg.to_str().unwrap()]));
    assert!(
        t.contains("compute.model") && t.contains("is an ACF model, not a HOG model"),
        "{t}"
    );
}
