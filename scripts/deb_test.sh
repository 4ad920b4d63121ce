#!/usr/bin/env bash
# The Debian package as a user installs it (README, "Install on an edge box"), run by CI through
# `make deb-test` (as root, like CI): dpkg -i, the installed files and the system user, the units
# verified with systemd-analyze, the installed binary run from / on installed files only (no
# checkout, no shared data: MOSAICD_DATA unset), then dpkg -r and dpkg --purge, each checked.
# A package left installed by a failed run is purged on exit.
#
#   bash scripts/deb_test.sh target/debian/mosaicd_0.1.0-1_amd64.deb
set -euo pipefail
deb=$(realpath "$1")
[ "$(id -u)" -eq 0 ] || { echo "deb-test: run as root (dpkg -i)" >&2; exit 2; }
unset MOSAICD_DATA
work=$(mktemp -d)
trap 'dpkg --purge mosaicd >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
passed=0
fail() { echo "deb-test: FAILED: $*" >&2; echo "deb-test: $passed passed, 1 failed"; exit 1; }
# Each step that reaches the next one passed.
step() { [ -z "${current:-}" ] || passed=$((passed + 1)); current=$1; echo "deb-test: $*"; }
cd /

step "dpkg -i $(basename "$deb")"
dpkg -i "$deb"
dpkg-query -W -f='${Status} ${Version}\n' mosaicd | grep -q "install ok installed" || fail "not installed"

step "installed files"
for f in /usr/bin/mosaicd /usr/lib/systemd/system/mosaicd.service /usr/lib/systemd/system/mosaicd@.service \
	/usr/lib/sysusers.d/mosaicd.conf /etc/mosaicd/mosaicd.toml /usr/share/mosaicd/models/mosaic_raw_srgb.json \
	/usr/share/doc/mosaicd/README.md /usr/share/doc/mosaicd/daemon.md /usr/share/doc/mosaicd/examples/mosaicd.toml \
	/usr/share/doc/mosaicd/examples/synthetic.toml /usr/share/mosaicd/clients/python/mosaicd_subscriber.py; do
	[ -f "$f" ] || fail "$f is missing"
done
dpkg-query -W -f='${Conffiles}\n' mosaicd | grep -q '^ /etc/mosaicd/mosaicd.toml ' || fail "/etc/mosaicd/mosaicd.toml is not a conffile"

step "system user (sysusers, applied in postinst)"
getent passwd mosaicd >/dev/null || fail "no user mosaicd"
id -nG mosaicd | tr ' ' '\n' | grep -qx video || fail "mosaicd is not in group video"

step "mosaicd.service enabled, not started"
[ -L /etc/systemd/system/multi-user.target.wants/mosaicd.service ] || fail "mosaicd.service is not enabled"
[ ! -e /etc/systemd/system/multi-user.target.wants/mosaicd@.service ] || fail "the template was enabled"

step "systemd-analyze verify (installed units)"
for unit in mosaicd.service mosaicd@front.service; do
	out=$(systemd-analyze verify "/usr/lib/systemd/system/$unit" 2>&1) || fail "verify $unit: $out"
	[ -z "$out" ] || fail "verify $unit warns: $out"
done
systemd-analyze security --offline=yes --no-pager /usr/lib/systemd/system/mosaicd.service | tail -1

step "the installed template: mosaicd check names the camera's device when it is absent"
if [ -e /dev/video0 ]; then
	mosaicd check --config /etc/mosaicd/mosaicd.toml || true
else
	out=$(mosaicd check --config /etc/mosaicd/mosaicd.toml 2>&1) && fail "check passed without /dev/video0: $out"
	echo "$out" | grep -q 'camera\[0\].device' || fail "check did not name camera[0].device: $out"
fi

step "the installed binary, from /, as user mosaicd: the installed synthetic example"
cfg=/usr/share/doc/mosaicd/examples/synthetic.toml
runuser -u mosaicd -- mosaicd check --config "$cfg"
out=$(runuser -u mosaicd -- mosaicd run --config "$cfg" --no-publish 2>&1) || fail "run: $out"
echo "$out" | grep 'frames processed'
echo "$out" | grep -q '90 frames processed of 90 captured' || fail "run: $out"

step "a relative model file resolves to /usr/share/mosaicd/models (config in $work, run from /)"
cat >"$work/low.toml" <<'EOF'
[publish]
enabled = false
[compute]
model = "mosaic_raw_srgb_low.json"
[[camera]]
name = "syn"
source = "synthetic"
width = 320
height = 240
frames = 5
EOF
mosaicd check --config "$work/low.toml" | tee "$work/check.txt"
grep -q '/usr/share/mosaicd/models/mosaic_raw_srgb_low.json' "$work/check.txt" || fail "model not resolved"
mosaicd run --config "$work/low.toml" 2>&1 | grep '5 frames processed of 5 captured' || fail "run low.toml"

step "the installed Python client reads a recording the installed binary made as user mosaicd"
chown mosaicd "$work"
printf '%s\n' '[publish]' 'enabled = false' '[record]' 'enabled = true' 'frames = true' \
	"path = \"$work/raw.mcap\"" '[compute]' 'detect = false' '[[camera]]' 'name = "syn"' \
	'source = "synthetic"' 'width = 64' 'height = 48' 'frames = 3' >"$work/rec.toml"
runuser -u mosaicd -- mosaicd run --config "$work/rec.toml" >/dev/null 2>&1 || fail "recording run"
n=$(python3 /usr/share/mosaicd/clients/python/read_recording.py "$work/raw.mcap" | grep -c '"bit_depth": 12') ||
	fail "read_recording.py"
[ "$n" -eq 3 ] || fail "read_recording.py printed $n frames, not 3"

step "dpkg -r: binary and units gone, conffile kept"
dpkg -r mosaicd
[ ! -e /usr/bin/mosaicd ] || fail "/usr/bin/mosaicd still there"
[ ! -e /usr/lib/systemd/system/mosaicd.service ] || fail "the unit is still there"
[ -f /etc/mosaicd/mosaicd.toml ] || fail "dpkg -r removed the conffile"
dpkg-query -W -f='${Status}\n' mosaicd | grep -q "config-files" || fail "not in state config-files"

step "dpkg --purge: conffile and enablement gone"
dpkg --purge mosaicd
[ ! -e /etc/mosaicd/mosaicd.toml ] || fail "purge left /etc/mosaicd/mosaicd.toml"
[ ! -e /etc/systemd/system/multi-user.target.wants/mosaicd.service ] || fail "purge left the enablement"
if dpkg-query -W -f='${Status}\n' mosaicd 2>/dev/null | grep -q installed; then fail "still known to dpkg"; fi
step "done"
echo "deb-test: $passed passed, 0 failed"
