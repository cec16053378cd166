#!/usr/bin/env bash
# Installs what is missing, builds, runs every test (unit, end-to-end, ROS integration), and
# ends with the line "N passed, N failed". Exit status non-zero on any failure.
#   scripts/test.sh               the whole suite
set -uo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

install_deps || { echo "0 passed, 1 failed"; exit 1; }
if ! build_workspace; then
  log "build failed"
  echo "0 passed, 1 failed"
  exit 1
fi
results="${FLEXCLOUD_WS}/build/test_results"
rm -rf "${results}"
run_log="${FLEXCLOUD_WS}/run_tests.log"
log "running the tests (log: ${run_log})"
# catkin_make run_tests exits 0 even when tests fail: the result files decide. It runs inside
# the workspace's environment, so rostest finds the package whatever the configure-time cache.
(cd "${FLEXCLOUD_WS}" && in_workspace catkin_make run_tests -j"$(nproc)" \
    -DCMAKE_BUILD_TYPE="${FLEXCLOUD_BUILD_TYPE}" -DPYTHON_EXECUTABLE=/usr/bin/python3) \
    > "${run_log}" 2>&1
grep -E "^(loop|open|a2rl|outage)" "${run_log}" >&2 || true
python3 "${FLEXCLOUD_ROOT}/scripts/count_results.py" "${results}"
