#!/usr/bin/env bash
# One-time machine set-up for mosaicd on Debian: system libraries the build needs and the Python
# oracles the parity tests and benchmarks compare against. Idempotent; fast when all is present.
set -euo pipefail
cd "$(dirname "$0")/.."

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

pkgs=()
# bindgen (used by v4l2-sys-mit and iceoryx2-pal-posix) needs libclang at build time.
if ! ls /usr/lib/llvm-*/lib/libclang.so* /usr/lib/x86_64-linux-gnu/libclang*.so* >/dev/null 2>&1; then
  pkgs+=(libclang-dev clang)
fi
# libfuzzer-sys compiles libFuzzer (C++) for the fuzz targets (`make fuzz-smoke`, run by CI).
command -v c++ >/dev/null 2>&1 || pkgs+=(g++)
# A TrueType font for the text in evaluation plots.
[ -f /usr/share/fonts/truetype/dejavu/DejaVuSans.ttf ] || pkgs+=(fonts-dejavu-core)
# systemd-analyze verifies the units in systemd/.
command -v systemd-analyze >/dev/null 2>&1 || pkgs+=(systemd)
# The aarch64 cross build (`make cross-test`): Debian's cross gcc and libc, qemu-user to run it.
command -v aarch64-linux-gnu-gcc >/dev/null 2>&1 || pkgs+=(gcc-aarch64-linux-gnu)
[ -f /usr/aarch64-linux-gnu/include/stdio.h ] || pkgs+=(libc6-dev-arm64-cross)
command -v qemu-aarch64 >/dev/null 2>&1 || pkgs+=(qemu-user)

if [ ${#pkgs[@]} -gt 0 ]; then
  echo "setup: installing ${pkgs[*]}" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${pkgs[@]}" >/dev/null
fi

# The Rust standard library for aarch64.
if ! rustup target list --installed 2>/dev/null | grep -qx aarch64-unknown-linux-gnu; then
  echo "setup: adding the rustup target aarch64-unknown-linux-gnu" >&2
  rustup target add aarch64-unknown-linux-gnu
fi

# cargo-deb builds the Debian package (`make deb`); pinned to the version the package was made with.
CARGO_DEB_VERSION=3.8.0
if ! cargo deb --version 2>/dev/null | grep -qx "cargo-deb $CARGO_DEB_VERSION"; then
  echo "setup: installing cargo-deb $CARGO_DEB_VERSION (cargo install, about 2 minutes)" >&2
  cargo install cargo-deb --locked --quiet --version "$CARGO_DEB_VERSION"
fi

# Python oracles: OpenCV 4.x (5.x dropped HOGDescriptor), scikit-image, colour-demosaicing, rawpy (LibRaw),
# and Prometheus's text-format parser (prometheus-client) for the metrics textfile.
if ! python3 -c 'import cv2, skimage, colour_demosaicing, numpy, rawpy, prometheus_client.parser; assert cv2.__version__.startswith("4.")' >/dev/null 2>&1; then
  echo "setup: installing Python oracles (tests/oracle/requirements.txt)" >&2
  python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore -r tests/oracle/requirements.txt
fi
# The Python clients (clients/python): the iceoryx2 wheel matching the daemon's crate version, mcap.
clients_ok='import mcap, zstandard, iceoryx2, importlib.metadata as m; assert m.version("iceoryx2") == "0.10.0"; assert (1, 2) <= tuple(int(x) for x in m.version("mcap").split(".")[:2]) < (2, 0)'
if ! python3 -c "$clients_ok" >/dev/null 2>&1; then
  echo "setup: installing the Python clients' packages (clients/python/requirements.txt)" >&2
  python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore -r clients/python/requirements.txt
  python3 -c "$clients_ok" || { echo "setup: the Python clients' packages still do not import" >&2; exit 1; }
fi
echo "setup: ok" >&2
