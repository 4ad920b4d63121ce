//! A recording replayed by the MCAP source: open (footer, summary and its CRC) and every frame
//! (chunk CRCs, record limits, the frame decoder, the frame-size limit). Errors are fine; panics,
//! hangs and unbounded allocations are not. From memory (`McapSource::from_bytes`: the same
//! checks as `McapSource::open` after it has opened the file).
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::capture::{McapSource, McapSourceOptions, Source};

fuzz_target!(|data: &[u8]| {
    let Ok(mut src) = McapSource::from_bytes(data, "fuzz.mcap", McapSourceOptions::default()) else {
        return;
    };
    for _ in 0..64 {
        match src.next_frame() {
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => break,
        }
    }
});
