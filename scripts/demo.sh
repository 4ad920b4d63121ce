#!/usr/bin/env bash
# `make demo` after the build: the demo recording (people in a corridor, built once from the shared
# data through the reverse ISP), then the daemon replaying it at its recorded rate.
# usage: scripts/demo.sh MOSAICD_BINARY
set -euo pipefail
bin=$1
data=${MOSAICD_DATA:?set MOSAICD_DATA to the shared data directory (README, Data)}
say() { echo "demo: $*" >&2; }
listen="$bin listen --camera demo --until-final"

if [ ! -f recordings/out/demo.mcap ]; then
  if [ -d "$data/pedestrian/usc/USCPedestrianSetB" ]; then
    say "building recordings/out/demo.mcap (about 10 s): 20 frames of USC Pedestrian Set B from $data"
    say "through the reverse ISP (USC's licence allows local use only: the file is never committed)"
    "$bin" record --recipe recordings/demo.toml
  elif [ -f "$data/raw/infinite_isp_8bit/Outdoor1_2592x1536_8bit_GRBG.raw" ]; then
    say "$data/pedestrian/usc is missing, so the recording with people cannot be built."
    say "Falling back to the park recording (recordings/park.toml): a real sensor frame WITHOUT people,"
    say "so every box it shows is a false positive."
    [ -f recordings/out/park.mcap ] || "$bin" record --recipe recordings/park.toml
    say "replaying recordings/out/park.mcap at its recorded rate; in another terminal: $listen"
    exec "$bin" replay recordings/out/park.mcap --camera demo --realtime
  else
    say "no demo data under $data (pedestrian/usc or raw/infinite_isp_8bit): set MOSAICD_DATA (README, Data)."
    say "Without any shared data: $bin run --config config/synthetic.toml"
    exit 1
  fi
fi
say "replaying recordings/out/demo.mcap at its recorded rate (60 frames at 5 fps, 12 s)."
say "A subscriber started before this, or during it, receives the frames: $listen"
exec "$bin" run
