//! The daemon's TOML configuration: parsing and `validate()`, then every typed accessor.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::config::Config;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(cfg) = Config::from_toml_str(text) else {
        return;
    };
    let _ = cfg.limits.frame_limits();
    let _ = cfg.compute.mosaic_taps_override();
    let _ = cfg.compute.mosaic_tone_override();
    let _ = cfg.compute.wb_gains();
    let _ = cfg.compute.svm_precision();
    for cam in &cfg.cameras {
        let _ = cam.cfa();
        let _ = cam.levels();
        let _ = cam.fourcc_bytes();
    }
});
