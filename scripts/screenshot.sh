#!/usr/bin/env bash
# Takes a picture of rviz showing a georeferenced simulated drive (demo.launch) under Xvfb, e.g.
# the README's doc/rviz.png. Needs the demo's drive (scripts/demo.sh makes it; made here if
# missing). Everything it starts (Xvfb, roslaunch with its master, rosout, the nodelet manager,
# rviz) is ended before it returns.
#   scripts/screenshot.sh OUTPUT.png
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
usage_or_help "usage: scripts/screenshot.sh OUTPUT.png   (rviz showing the demo's drive, taken under Xvfb)" "${1:-}"
out="$(realpath -m "$1")"
mkdir -p "$(dirname "${out}")"
install_deps
[ -f "${FLEXCLOUD_WS}/devel/setup.bash" ] || build_workspace
drive="${FLEXCLOUD_ROOT}/out/demo/drive"
[ -f "${drive}/drive.bag" ] || "${FLEXCLOUD_WS}/devel/lib/flexcloud/simulate_drive" --out "${drive}" --map-points 1000000

# Each background job in a process group of its own, so that ending the group ends every
# process roslaunch started (its master, rosout, the nodelet manager, rviz).
set -m
display=":$((90 + RANDOM % 9))"
Xvfb "${display}" -screen 0 1400x900x24 >/dev/null 2>&1 &
xvfb=$!
port=$((11400 + RANDOM % 500))
export ROS_MASTER_URI="http://localhost:${port}"
end_group() {  # SIGINT first (roslaunch shuts its nodes down), then SIGKILL what is left
  local group="$1" i
  kill -INT -- "-${group}" 2>/dev/null || return 0
  for i in $(seq 50); do
    kill -0 -- "-${group}" 2>/dev/null || return 0
    sleep 0.2
  done
  kill -KILL -- "-${group}" 2>/dev/null || true
}
cleanup() {
  [ -n "${launch:-}" ] && end_group "${launch}"
  end_group "${xvfb}"
  wait 2>/dev/null || true
}
trap cleanup EXIT
sleep 2
log_file="$(mktemp /tmp/flexcloud_screenshot.XXXXXX.log)"
DISPLAY="${display}" in_workspace roslaunch -p "${port}" flexcloud demo.launch drive:="${drive}" \
  >"${log_file}" 2>&1 &
launch=$!
log "waiting for rviz to render the georeferenced map (log: ${log_file})"
sleep "${SCREENSHOT_WAIT:-40}"
DISPLAY="${display}" import -window root "${out}"
log "wrote ${out}"
