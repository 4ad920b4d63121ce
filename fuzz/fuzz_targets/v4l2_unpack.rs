//! The V4L2 unpackers (8-bit, 16-bit little-endian, MIPI 10/12-bit packed): geometry from the
//! first bytes (FourCC choice, width, height, bytesperline as a driver could report them), the rest
//! is the buffer. The parallel and serial unpackers must agree.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::capture::{
    bayer_format, raw_frame_from_v4l2, unpack_into, unpack_into_serial, SUPPORTED, SUPPORTED_PACKED12,
};

fuzz_target!(|data: &[u8]| {
    if data.len() < 13 {
        return;
    }
    let fourccs: Vec<[u8; 4]> = SUPPORTED.iter().chain(&SUPPORTED_PACKED12).copied().collect();
    let Ok(fmt) = bayer_format(fourccs[data[0] as usize % fourccs.len()]) else {
        return;
    };
    let word = |i: usize| u32::from_le_bytes([data[i], data[i + 1], data[i + 2], data[i + 3]]) as usize;
    // Widths and heights up to 2^32 (a driver's u32), strides anything.
    let (w, h, bpl) = (word(1), word(5), word(9));
    let buf = &data[13..];
    let _ = raw_frame_from_v4l2(&fmt, buf, w, h, bpl, None);
    // Unpack into a destination of the size the geometry needs, when that is small.
    if let Some(n) = w.checked_mul(h).filter(|&n| n <= 1 << 16) {
        let (mut a, mut b) = (vec![0u16; n], vec![0u16; n]);
        let pa = unpack_into(&fmt, buf, w, h, bpl, &mut a);
        let pb = unpack_into_serial(&fmt, buf, w, h, bpl, &mut b);
        assert_eq!(pa.is_ok(), pb.is_ok());
        if pa.is_ok() {
            assert_eq!(a, b);
        }
    }
});
