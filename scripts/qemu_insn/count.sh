#!/usr/bin/env bash
# Counts the guest instructions an aarch64 program executes under qemu-user (insn.c's plugin).
# Usage: scripts/qemu_insn/count.sh [-cpu MODEL] AARCH64_BINARY ARGS...
# Prints the program's output, then "qemu-insn: N guest instructions" on stderr. Run the program with
# one worker thread (e.g. `--threads 1`). Needs gcc, qemu-user and the aarch64 sysroot (README,
# "Building for aarch64"). Example (NEON against the portable code, the default detector settings):
#   for k in neon scalar; do MOSAICD_KERNELS=$k scripts/qemu_insn/count.sh \
#     target/aarch64-unknown-linux-gnu/release/mosaicd bench detect --no-peer --frames 1 --threads 1; done
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cpu=max
if [[ "${1:-}" == "-cpu" ]]; then cpu="$2"; shift 2; fi
out="${CARGO_TARGET_DIR:-$here/../../target}/qemu_insn"
mkdir -p "$out"
if [[ ! "$out/libinsn.so" -nt "$here/insn.c" ]]; then
  gcc -O2 -shared -fPIC -o "$out/libinsn.so" "$here/insn.c"
fi
exec qemu-aarch64 -cpu "$cpu" -L "${AARCH64_SYSROOT:-/usr/aarch64-linux-gnu}" -plugin "$out/libinsn.so" "$@"
