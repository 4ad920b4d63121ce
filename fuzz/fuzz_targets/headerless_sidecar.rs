//! A headerless raw file and its TOML sidecar: the input is the sidecar's text, a NUL byte, and the
//! file's bytes. The sidecar parses into the loader's `RawFormat`, which reads the bytes from
//! memory. When that gives a frame, the same bytes go through the file loader too (its `stat`
//! and size check, then the same parser), which must agree: a file per input only then, so that
//! the fuzzer runs at the speed of the parsers.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::capture::Sidecar;
use mosaicd::raw::{frame_from_bytes, load_headerless};

fuzz_target!(|data: &[u8]| {
    let (text, bytes) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let Ok(text) = std::str::from_utf8(text) else {
        return;
    };
    let Ok(sidecar) = toml::from_str::<Sidecar>(text) else {
        return;
    };
    let origin = std::path::Path::new("fuzz.raw.toml");
    let Ok(fmt) = sidecar.format(origin) else {
        return;
    };
    let from_memory = frame_from_bytes(bytes, &fmt, origin);
    if let Ok(frame) = from_memory {
        let path = mosaicd_fuzz::scratch_file("in.raw", bytes);
        let from_file = load_headerless(&path, &fmt).expect("the file loader refused what memory loaded");
        assert_eq!(
            frame.to_u16_vec(),
            from_file.to_u16_vec(),
            "memory and file loaders disagree"
        );
    }
});
