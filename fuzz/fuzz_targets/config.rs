//! The daemon's TOML configuration: parsing (every typed key parsed as it is read) and
//! `validate()`, then the accessors that derive values from it.
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
    let _ = cfg.compute.model_key();
    let _ = cfg.compute.svm.precision();
    for cam in &cfg.cameras {
        let _ = cam.levels();
    }
});
