#!/usr/bin/env bash
# Soak run of the daemon as a service runs it (docs/daemon.md, "Soak"): a live-paced synthetic
# 1080p 12-bit camera with detection, publishing over iceoryx2 to a subscriber that is killed and
# restarted every 30 s, and recording into a rotating ring of files. Samples the daemon's resident
# memory and open file descriptors every 10 s, stops it with SIGTERM after DURATION seconds and
# summarises: memory after warm-up vs at the end, descriptors, frames, drops, failures, files kept.
#
#   scripts/soak.sh                      # 10 minutes
#   DURATION=3600 scripts/soak.sh        # an hour
#
# Environment: MOSAICD (binary, default target/release/mosaicd), OUT (default out/soak),
# DURATION (seconds, default 600), FPS (default 15), WIDTH x HEIGHT (default 1920 x 1080),
# THREADS (default 2), SVM (f32 or i8, default f32), APPROX (compute.approx_levels, default 14),
# MODEL (compute.model: a built-in name or an absolute path, default mosaic, the built-in
# models/mosaic.json; mosaic-raw-srgb runs the srgb tone, with grey-world gains on every frame of
# the synthetic camera, which has none).
# Needs no shared data (the shipped models). Exit status: the daemon's.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${MOSAICD:-target/release/mosaicd}
out=${OUT:-out/soak}
duration=${DURATION:-600}
[ -x "$bin" ] || { echo "soak: no binary at $bin (cargo build --release)" >&2; exit 2; }
mkdir -p "$out"
rm -f "$out"/soak*.mcap "$out"/samples.csv
prefix="mosaicd-soak-$$"
cat >"$out/soak.toml" <<EOF
[daemon]
threads = ${THREADS:-2}
stats_interval_ms = 1000
[publish]
service_prefix = "$prefix"
[record]
enabled = true
path = "$out/soak.mcap"
rotate_secs = 60
max_files = 3
[compute]
model = "${MODEL:-mosaic}"
approx_levels = ${APPROX:-14}
svm = "${SVM:-f32}"
[[camera]]
name = "soak"
source = "synthetic"
width = ${WIDTH:-1920}
height = ${HEIGHT:-1080}
bit_depth = 12
fps = ${FPS:-15}
frames = 0
live = true
EOF

"$bin" run --config "$out/soak.toml" --log warn >"$out/summary.txt" 2>"$out/daemon.log" &
pid=$!
sub=
stop_all() {
  kill -TERM "$pid" 2>/dev/null || true
  if [ -n "$sub" ]; then kill -KILL "$sub" 2>/dev/null || true; fi
}
trap stop_all EXIT
# Ready when a first detections message arrives (a signal before then would find no handler).
"$bin" listen --prefix "$prefix" --camera soak --count 1 --timeout-s 120 --log error >/dev/null 2>&1 &
ready=$!
while kill -0 "$ready" 2>/dev/null && [ -d "/proc/$pid" ]; do sleep 0.2; done
kill -KILL "$ready" 2>/dev/null || true
echo "t_s,rss_kib,fds" >"$out/samples.csv"
start=$(date +%s)
next_sub=0
while :; do
  now=$(( $(date +%s) - start ))
  rss=$(awk '/^VmRSS:/ {print $2}' "/proc/$pid/status" 2>/dev/null) || break
  fds=$(ls "/proc/$pid/fd" 2>/dev/null | wc -l) || break
  [ -n "$rss" ] || { echo "soak: the daemon exited early" >&2; break; }
  echo "$now,$rss,$fds" >>"$out/samples.csv"
  # A subscriber that dies: killed (SIGKILL, no clean-up) and replaced every 30 s.
  if [ "$now" -ge "$next_sub" ]; then
    if [ -n "$sub" ]; then kill -KILL "$sub" 2>/dev/null || true; fi
    "$bin" listen --prefix "$prefix" --camera soak --log error >/dev/null 2>&1 &
    sub=$!
    disown "$sub"
    next_sub=$(( now + 30 ))
  fi
  [ "$now" -ge "$duration" ] && break
  sleep 10
done
kill -TERM "$pid" 2>/dev/null || true
set +e
wait "$pid"
status=$?
set -e
trap - EXIT
if [ -n "$sub" ]; then kill -KILL "$sub" 2>/dev/null || true; fi
python3 - "$out" "$status" <<'EOF'
import csv, glob, os, sys
out, status = sys.argv[1], int(sys.argv[2])
rows = [(int(r["t_s"]), int(r["rss_kib"]), int(r["fds"])) for r in csv.DictReader(open(f"{out}/samples.csv"))]
if not rows:
    sys.exit(f"soak: no samples (exit status {status}); see {out}/daemon.log: " + open(f"{out}/daemon.log").read()[-2000:])
warm = [r for r in rows if r[0] >= 60] or rows
mib = lambda k: k / 1024
print(f"soak: {rows[-1][0]} s, exit status {status}")
print(f"  resident memory: after warm-up (t = {warm[0][0]} s) {mib(warm[0][1]):.1f} MiB, "
      f"max after warm-up {mib(max(r[1] for r in warm)):.1f} MiB, at the end {mib(rows[-1][1]):.1f} MiB")
print(f"  open descriptors: after warm-up {warm[0][2]}, max {max(r[2] for r in rows)}, at the end {rows[-1][2]}")
files = sorted(os.path.basename(p) for p in glob.glob(f"{out}/soak*.mcap"))
print(f"  recording files kept: {len(files)} ({', '.join(files)})")
for line in open(f"{out}/summary.txt"):
    print("  " + line.rstrip())
EOF
exit "$status"
