//! PGM from bytes (the header parser, then the mosaic), and PNG through the dispatcher (grey PNGs
//! as mosaics with the `tEXt` description, colour PNGs resampled), all under the frame-size
//! limit. From memory (`load_input_bytes`: the dispatcher of `load_input` without the files'
//! `stat` and read).
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::raw::{load_input_bytes, pgm_from_bytes, InputOptions};
use mosaicd::raw::Cfa;

fuzz_target!(|data: &[u8]| {
    let opts = InputOptions {
        cfa: Some(Cfa::Rggb),
        ..InputOptions::default()
    };
    if data.starts_with(b"P5") {
        let header = pgm_from_bytes(data, "fuzz.pgm".as_ref());
        let mosaic = load_input_bytes(data, "fuzz.pgm".as_ref(), &opts);
        // The mosaic adds only checks to the parse.
        assert!(header.is_ok() || mosaic.is_err(), "mosaic without a parse");
    } else {
        let _ = load_input_bytes(data, "fuzz.png".as_ref(), &opts);
    }
});
