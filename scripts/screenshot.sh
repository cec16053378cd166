#!/usr/bin/env bash
# Takes a picture of rviz showing a georeferenced simulated drive (demo.launch) under Xvfb, e.g.
# the README's doc/rviz.png. Needs the demo's drive (scripts/demo.sh makes it; made here if
# missing). Everything it starts (Xvfb, roslaunch with its master, rosout, the nodelet manager,
# rviz) is ended before it returns.
#   scripts/screenshot.sh OUTPUT.png
# It waits for the node's run, then until rviz has drawn the map, and fails if either never
# comes. Environment: SCREENSHOT_TIMEOUT (s, default 300) bounds the wait; SCREENSHOT_MIN_SHARE
# (default 0.02) is the share of the 3D view the map must cover; SCREENSHOT_SETTLE (s, default 3)
# is the wait before the picture once it does.
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
# The node's run first (~result has a result), then rviz: a picture every few seconds until the
# map covers a share of the 3D view (scripts/map_drawn.py), then one more a moment later.
deadline=$((SECONDS + ${SCREENSHOT_TIMEOUT:-300}))
log "waiting for the node to georeference the drive (log: ${log_file})"
has_result() {
  in_workspace timeout 10 rostopic echo -n 1 /flexcloud/result/has_result 2>/dev/null | \
    grep -q True
}
until has_result; do
  if [ "${SECONDS}" -ge "${deadline}" ] || ! kill -0 "${launch}" 2>/dev/null; then
    log "the node never georeferenced the drive (log: ${log_file})"
    exit 1
  fi
  sleep 1
done
log "waiting for rviz to draw the georeferenced map"
shot="$(mktemp /tmp/flexcloud_screenshot.XXXXXX.png)"
share=0
until DISPLAY="${display}" import -window root "${shot}" && \
      share="$(/usr/bin/python3 "${FLEXCLOUD_ROOT}/scripts/map_drawn.py" "${shot}")" && \
      /usr/bin/python3 -c "import sys; sys.exit(float(sys.argv[1]) < ${SCREENSHOT_MIN_SHARE:-0.02})" "${share}"; do
  if [ "${SECONDS}" -ge "${deadline}" ]; then
    rm -f "${shot}"
    log "rviz never drew the map: it covers ${share} of the view (log: ${log_file})"
    exit 1
  fi
  sleep 3
done
sleep "${SCREENSHOT_SETTLE:-3}"  # the last points of the cloud
DISPLAY="${display}" import -window root "${shot}"
mv "${shot}" "${out}"
log "wrote ${out} (the map covers $(/usr/bin/python3 "${FLEXCLOUD_ROOT}/scripts/map_drawn.py" "${out}") of the view)"
