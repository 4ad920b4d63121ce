//! Camera raw files: the Kodak RADC decoder (by TIFF make and model) and rawloader, whose caught
//! panics must stay caught (and off stderr).
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::raw::load::load_camera_raw;

fuzz_target!(|data: &[u8]| {
    let path = mosaicd_fuzz::scratch_file("in.kdc", data);
    let _ = load_camera_raw(&path);
});
