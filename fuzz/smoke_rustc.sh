#!/usr/bin/env bash
# RUSTC_WRAPPER for `make fuzz-smoke-build` (docs/fuzzing.md, "The CI smoke build"): adds the fuzz
# flags ($FUZZ_RUSTFLAGS: SanitizerCoverage, overflow checks, debug assertions, --cfg fuzzing) to
# the crates that parse the fuzzers' input (mosaicd, the fuzz targets, and the format crates
# below) and compiles every other crate (iceoryx2, tokio, foxglove, plotters, clap, rayon, ...:
# none of them parses a target's input) plainly. Build scripts and proc macros (compiled without
# --target) are never instrumented. Cargo does not see these flags: `make fuzz-smoke-build` removes
# the smoke build ($FUZZ_TARGET_DIR/<host>/smoke) when this file is newer than its last build.
set -euo pipefail
rustc=$1
shift
name=
target=
prev=
for a in "$@"; do
    case $prev in
        --crate-name) name=$a ;;
        --target) target=$a ;;
    esac
    prev=$a
done
if [ -n "$target" ]; then
    case $name in
        mosaicd | mosaicd_fuzz | mcap_source | raw_frame_message | headerless_sidecar | pgm_png | \
        camera_raw | model_files | config | v4l2_unpack | \
        mcap | binrw | lz4 | zstd | zstd_safe | crc32fast | byteorder | byteorder_lite | \
        png | fdeflate | miniz_oxide | flate2 | adler2 | simd_adler32 | image | zune_core | \
        zune_jpeg | jpeg_decoder | moxcms | rawloader | serde | serde_core | serde_json | \
        toml | toml_parser | toml_datetime | serde_spanned | winnow)
            # shellcheck disable=SC2086 # FUZZ_RUSTFLAGS is a list of flags
            exec "$rustc" "$@" $FUZZ_RUSTFLAGS
            ;;
    esac
fi
exec "$rustc" "$@"
