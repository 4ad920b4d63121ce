//! Every config file we ship parses and validates, and the documented default file documents
//! every key the daemon knows.

use std::path::Path;

use mosaicd::config::Config;

fn load(name: &str) -> Config {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("config").join(name);
    Config::load(&p).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn shipped_configs_validate() {
    for name in [
        "mosaicd.toml",
        "replay.toml",
        "camera.toml",
        "multi-camera.toml",
        "synthetic.toml",
        "system.toml",
        "acf.toml",
    ] {
        let c = load(name);
        assert!(!c.cameras.is_empty(), "{name}");
    }
    assert_eq!(load("multi-camera.toml").cameras.len(), 2);
}

#[test]
fn default_config_equals_built_in_defaults_and_mentions_every_key() {
    let c = load("mosaicd.toml");
    let d = Config::default();
    assert_eq!(c.daemon, d.daemon);
    assert_eq!(c.publish, d.publish);
    assert_eq!(c.record, d.record);
    assert_eq!(c.compute, d.compute);
    assert_eq!(c.limits, d.limits);
    assert_eq!(c.foxglove, d.foxglove);
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("config/mosaicd.toml")).unwrap();
    let keys = toml::Value::try_from(&c).unwrap();
    for (section, table) in keys.as_table().unwrap() {
        let table = match table {
            toml::Value::Array(a) => a[0].as_table().unwrap().clone(),
            t => t.as_table().unwrap().clone(),
        };
        for key in table.keys() {
            assert!(
                text.contains(key.as_str()),
                "config/mosaicd.toml does not document {section}.{key}"
            );
        }
    }
}

#[test]
fn a_bad_value_in_a_file_names_the_file_key_and_range() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    std::fs::write(
        &p,
        "[daemon]\nmax_in_flight = 100\n[[camera]]\nname = \"a\"\nsource = \"synthetic\"\n",
    )
    .unwrap();
    let msg = Config::load(&p).unwrap_err().to_string();
    assert!(
        msg.contains("daemon.max_in_flight") && msg.contains("1..=64"),
        "{msg}"
    );
}

#[test]
fn the_no_shared_data_examples_run_without_shared_data() {
    // README and docs/daemon.md: these commands need nothing from the shared data directory.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let empty = tempfile::tempdir().unwrap();
    let out = empty.path().join("pan.mcap");
    for (args, want) in [
        (
            vec!["run", "--config", "config/synthetic.toml", "--no-publish"],
            "90 frames processed of 90 captured",
        ),
        (
            vec![
                "replay",
                "recordings/synthetic_pan.mcap",
                "--config",
                "config/synthetic.toml",
                "--out",
                out.to_str().unwrap(),
                "--no-publish",
            ],
            "12 frames processed of 12 captured",
        ),
        (
            vec!["run", "--config", "config/acf.toml", "--no-publish"],
            "12 frames processed of 12 captured",
        ),
    ] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_mosaicd"))
            .args(&args)
            .current_dir(root)
            .env(mosaicd::data::DATA_ENV, empty.path())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{args:?}: {err}");
        let text = format!("{}{err}", String::from_utf8_lossy(&o.stdout));
        assert!(text.contains(want), "{args:?}: {text}");
    }
    assert!(out.metadata().unwrap().len() > 0);
}
