#!/usr/bin/env bash
# Takes doc/rviz.png: rviz with a georeferenced simulated drive (demo.launch) under Xvfb.
# Needs the demo's drive (scripts/demo.sh makes it; made here if missing).
#   scripts/screenshot.sh [OUTPUT.png]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
install_deps
[ -f "${FLEXCLOUD_WS}/devel/setup.bash" ] || build_workspace
out="${1:-${FLEXCLOUD_ROOT}/doc/rviz.png}"
drive="${FLEXCLOUD_ROOT}/out/demo/drive"
[ -f "${drive}/drive.bag" ] || "${FLEXCLOUD_WS}/devel/lib/flexcloud/simulate_drive" --out "${drive}" --map-points 1000000

display=":$((90 + RANDOM % 9))"
Xvfb "${display}" -screen 0 1400x900x24 >/dev/null 2>&1 &
xvfb=$!
port=$((11400 + RANDOM % 500))
export ROS_MASTER_URI="http://localhost:${port}"
cleanup() { kill "${launch:-0}" "${xvfb}" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT
sleep 2
DISPLAY="${display}" in_workspace roslaunch -p "${port}" flexcloud demo.launch drive:="${drive}" >/tmp/flexcloud_screenshot.log 2>&1 &
launch=$!
log "waiting for rviz to render the georeferenced map"
sleep "${SCREENSHOT_WAIT:-40}"
DISPLAY="${display}" import -window root "${out}"
log "wrote ${out}"
