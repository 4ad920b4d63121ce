#!/usr/bin/env bash
# The aarch64 detection check of `make cross-test`: `mosaicd detect` on one real frame (USC
# pedestrian set A, group_5.bmp: six people, 200x148, read through an RGGB filter as a mosaic,
# our shipped mosaic model, pyramid magnified twice, every window above the threshold kept:
# no suppression), once by the x86-64 binary and once by the aarch64 binary under qemu-user. The
# boxes must be identical and the scores equal within 1e-4 (the two C libraries' float functions
# may differ in the last bit), and there must be at least one box, so a detector that finds
# nothing on both cannot pass.
#
# usage: scripts/cross_detect.sh X86_BINARY "AARCH64_COMMAND"   (the command may start with a runner)
set -euo pipefail
cd "$(dirname "$0")/.."
x86=$1
arm=$2
data=${MOSAICD_DATA:-../shared/data}
img=$data/pedestrian/usc/USCPedestrianSetA/group_5.bmp
if [ ! -f "$img" ]; then
  echo "cross_detect: $img not found: set MOSAICD_DATA to the shared data directory (README, Data)" >&2
  exit 1
fi
base=(detect "$img" --as mosaic --cfa RGGB --model models/mosaic_raw_srgb.json --upsample 2 --nms none --threads 2 --json)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
start=$(date +%s)
# Each setting named on both sides: `detect`'s default `--svm auto` is i8 on x86-64 and f32 on
# aarch64, so the defaults themselves differ in arithmetic by design. The exact pyramid with f32,
# then the default pyramid with the 8-bit SVM (exact integer sums: NEON sdot against x86's kernel).
for setting in "--approx 1 --svm f32" "--approx 14 --svm i8"; do
  # shellcheck disable=SC2206 # the setting is two flags and their values
  args=("${base[@]}" $setting)
  "$x86" "${args[@]}" >"$tmp/x86.json"
  # shellcheck disable=SC2086 # the aarch64 command is a runner and its arguments, then the binary
  $arm "${args[@]}" >"$tmp/aarch64.json"
  python3 - "$tmp/x86.json" "$tmp/aarch64.json" "$setting" <<'PY'
import json, sys
a, b = (json.load(open(p))["detections"] for p in sys.argv[1:3])
setting = sys.argv[3]
key = lambda d: {k: v for k, v in d.items() if k != "score"}
if not a:
    sys.exit(f"cross_detect ({setting}): the x86-64 binary found no box: the check needs at least one")
if [key(d) for d in a] != [key(d) for d in b]:
    sys.exit(f"cross_detect ({setting}): boxes differ\n  x86-64:  {a}\n  aarch64: {b}")
worst = max(abs(p["score"] - q["score"]) for p, q in zip(a, b))
if worst > 1e-4:
    sys.exit(f"cross_detect ({setting}): scores differ by up to {worst:.3g}\n  x86-64:  {a}\n  aarch64: {b}")
print(f"cross_detect ({setting}): {len(a)} boxes identical on x86-64 and aarch64 (qemu), scores within {worst:.2g}")
PY
done
echo "cross_detect: $(($(date +%s) - start)) s" >&2
