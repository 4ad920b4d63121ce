//! PGM from bytes and from a file, and PNG through the dispatcher (grey PNGs as mosaics with the
//! `tEXt` description, colour PNGs resampled), all under the frame-size limit.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::raw::load::{load_input, pgm_from_bytes, InputOptions};
use mosaicd::raw::Cfa;

fuzz_target!(|data: &[u8]| {
    let opts = InputOptions {
        cfa: Some(Cfa::Rggb),
        ..InputOptions::default()
    };
    if data.starts_with(b"P5") {
        let _ = pgm_from_bytes(data, "fuzz.pgm".as_ref());
        let path = mosaicd_fuzz::scratch_file("in.pgm", data);
        let _ = load_input(&path, &opts);
    } else {
        let path = mosaicd_fuzz::scratch_file("in.png", data);
        let _ = load_input(&path, &opts);
    }
});
