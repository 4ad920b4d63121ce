//! A headerless raw file and its TOML sidecar: the input is the sidecar's text, a NUL byte, and the
//! file's bytes. The sidecar parses into the loader's `RawFormat`, which reads the bytes; also the
//! file through the path loader (stat before read).
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::capture::files::Sidecar;
use mosaicd::raw::load::{frame_from_bytes, load_headerless};

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
    let path = mosaicd_fuzz::scratch_file("in.raw", bytes);
    let from_file = load_headerless(&path, &fmt);
    assert_eq!(
        from_memory.is_ok(),
        from_file.is_ok(),
        "memory and file loaders disagree"
    );
});
