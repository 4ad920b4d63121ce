//! One `mosaicd.RawFrame` message body: the header parser and the frame decoder.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::raw::FrameLimits;
use mosaicd::wire::schema::{decode_raw_frame, decode_raw_frame_header};

fuzz_target!(|data: &[u8]| {
    if let Ok((h, _)) = decode_raw_frame_header(data) {
        // The MCAP source checks the limit from the header before decoding: so does this target.
        if FrameLimits::process()
            .check(h.width.into(), h.height.into())
            .is_err()
        {
            return;
        }
    }
    let _ = decode_raw_frame(data);
});
