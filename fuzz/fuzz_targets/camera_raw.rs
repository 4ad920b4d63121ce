//! Camera raw files: the Kodak RADC decoder (by TIFF make and model) and rawloader, whose caught
//! panics must stay caught (and off stderr). From memory: the file loader `load_camera_raw` is
//! its `stat` and bounded read, then this same `camera_raw_from_bytes`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::raw::camera_raw_from_bytes;

fuzz_target!(|data: &[u8]| {
    let _ = camera_raw_from_bytes(data, "fuzz.kdc".as_ref());
});
