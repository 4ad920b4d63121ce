//! Every model in `models/` loads and validates, is in the domain and input pipeline its name
//! says, reads the mosaic in the tone its name says, and records the training command (docs/detection.md, "The shipped models").
//! The ACF models (`acf-*.json`, docs/acf.md "Shipped models") likewise, and were trained on every
//! training file with the full schedule.

use std::path::Path;

use mosaicd::detect::AcfModel;
use mosaicd::detect::Domain;
use mosaicd::detect::LinearModel;
use mosaicd::features::hog::MosaicTone;

#[test]
fn shipped_models_load_and_say_how_they_were_made() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".json") && !n.starts_with("acf-"))
        .collect();
    names.sort();
    assert!(names.len() >= 5, "{names:?}");
    for name in &names {
        let m = LinearModel::load(&dir.join(name), Domain::Mosaic).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.weights.len(), 3780, "{name}");
        let want = if name.starts_with("colour") {
            Domain::Colour
        } else {
            Domain::Mosaic
        };
        assert_eq!(m.domain, want, "{name}");
        let cmd = m.provenance["command"].as_str().unwrap_or_default();
        // (Some were written under another name and renamed, so the command's --out may differ.)
        let domain = if want == Domain::Colour {
            "colour"
        } else {
            "mosaic"
        };
        assert!(
            cmd.contains("mosaicd train") && cmd.contains(&format!("--domain {domain}")),
            "{name}: {cmd:?}"
        );
        let input = m.provenance["input_pipeline"].as_str().unwrap_or_default();
        let want_input = match name.trim_end_matches(".json").split('_').nth(1) {
            None => "sampled",
            Some("raw") if name.ends_with("_low.json") => "raw-low",
            Some("raw") => "raw-clean",
            Some(other) => panic!("{name}: unexpected model name part {other}"),
        };
        assert_eq!(input, want_input, "{name}");
        // the tone the model reads: srgb only where the name says so (docs: "The mosaic's tone")
        let tone = if name.ends_with("_srgb.json") || name.contains("_srgb_") {
            MosaicTone::Srgb
        } else {
            MosaicTone::Linear
        };
        assert_eq!(m.mosaic_tone, tone, "{name}");
        assert_eq!(
            cmd.contains("--mosaic-tone srgb"),
            tone == MosaicTone::Srgb,
            "{name}: {cmd:?}"
        );
    }
}

#[test]
fn shipped_acf_models_load_and_say_how_they_were_made() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
    for (name, domain, input, tone) in [
        ("acf-mosaic.json", Domain::Mosaic, "raw-clean", MosaicTone::Srgb),
        ("acf-colour.json", Domain::Colour, "sampled", MosaicTone::Linear),
    ] {
        let m = AcfModel::load(&dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((m.domain, m.mosaic_tone), (domain, tone), "{name}");
        assert_eq!(m.classifier.trees.len(), 2048, "{name}");
        let p = &m.provenance;
        let cmd = p["command"].as_str().unwrap_or_default();
        assert!(
            cmd.contains("mosaicd train --detector acf")
                && cmd.contains(&format!("--domain {}", domain.name()))
                && cmd.contains(&format!("--out models/{name}")),
            "{name}: {cmd:?}"
        );
        assert_eq!(p["input_pipeline"], input, "{name}");
        assert_eq!(p["val_fraction"], 0.0, "{name}: trained on every training file");
        assert_eq!(
            cmd.contains("--mosaic-tone srgb"),
            tone == MosaicTone::Srgb,
            "{name}"
        );
    }
}
