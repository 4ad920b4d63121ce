#!/usr/bin/env bash
# Fill the fuzz corpora (one directory per target under $1) from the repository's own files and
# the committed seeds in fuzz/seeds/: configs and recipes for `config`; models (each behind the
# format-selector byte) and recordings are small files written by mosaicd itself (fuzz/seeds/,
# made by `make fuzz-seeds`; docs/fuzzing.md).
# Existing corpus files are kept: long runs build on what earlier runs found.
set -euo pipefail
out=${1:?usage: fuzz/seed.sh CORPUS_DIR}
here=$(cd "$(dirname "$0")" && pwd)
repo=$(dirname "$here")
for t in mcap_source raw_frame_message headerless_sidecar pgm_png camera_raw model_files config v4l2_unpack; do
    mkdir -p "$out/$t"
    if [ -d "$here/seeds/$t" ]; then
        cp -n "$here/seeds/$t"/* "$out/$t/" 2>/dev/null || true
    fi
done
# The configs without their comment lines and blank lines (mosaicd.toml: 18 KB, 1 KB of it keys and
# values): every input is parsed whole, and the comments, all the same to the parser, made the
# config target 3-4x slower. The smallest commented files are kept as they are, for the comment
# syntax.
for f in "$repo"/config/*.toml "$repo"/config/cameras/*.toml "$repo"/recordings/*.toml; do
    [ -f "$f" ] || continue
    dest="$out/config/$(basename "$f")"
    if [ "$(wc -c < "$f")" -le 1024 ]; then
        cp -n "$f" "$dest"
    elif [ ! -e "$dest" ]; then
        grep -v -e '^[[:space:]]*#' -e '^[[:space:]]*$' "$f" > "$dest" || true
    fi
done
