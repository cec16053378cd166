#!/usr/bin/env bash
# Run by scripts/test_platform.sh inside the platform's chroot: the repository at /repo, the
# workspace at /ws, the results to /results. Builds the package and its tests and runs the unit
# tests, the offline tool's end-to-end tests and the node's rostest (live.test).
set -uo pipefail
export FLEXCLOUD_WS=/ws FLEXCLOUD_BUILD_TYPE=Release
source /repo/scripts/common.sh
say() { echo "[platform] $*"; }

say "$(. /etc/os-release && echo "${PRETTY_NAME}"): gcc $(gcc -dumpfullversion)," \
    "cmake $(cmake --version | head -1 | cut -d' ' -f3), Ceres $(dpkg-query -W -f '${Version}' \
    libceres-dev), PCL $(dpkg-query -W -f '${Version}' libpcl-dev), Eigen $(dpkg-query -W \
    -f '${Version}' libeigen3-dev), PROJ $(dpkg-query -W -f '${Version}' libproj-dev)"
# A fresh configure every run (the compiles come from the ccache): catkin 0.8.9 caches
# googletest's libraries from the first configure and names them as files on the next one.
rm -rf "${FLEXCLOUD_WS}/build" "${FLEXCLOUD_WS}/devel"
clean_ros_env
link_package "${FLEXCLOUD_WS}"
(cd "${FLEXCLOUD_WS}" && catkin_make -j"$(nproc)" -DCMAKE_BUILD_TYPE=Release \
  "${CCACHE_ARGS[@]}" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  all flexcloud_unit_tests flexcloud_e2e_tests flexcloud_ros_tests) ||
  { say "the build failed"; exit 1; }
say "built"

rc=0
bin="${FLEXCLOUD_WS}/devel/lib/flexcloud"
for t in flexcloud_unit_tests flexcloud_e2e_tests; do
  "${bin}/${t}" --gtest_output="xml:/results/${t}.xml" > "/results/${t}.log" 2>&1 || rc=1
  say "${t}: $(grep -E '^\[  (PASSED|FAILED)  \] [0-9]+ test' "/results/${t}.log" | tr '\n' ' ')"
done
# A master port of its own: the chroot shares the machine's network.
(export ROS_TEST_RESULTS_DIR=/results/ros ROS_LOG_DIR=/results/ros_log ROS_HOME=/results/ros_home \
   ROS_MASTER_URI=http://localhost:11471 ROS_HOSTNAME=localhost &&
  in_workspace rostest flexcloud live.test) > /results/live.log 2>&1 || rc=1
say "live.test: $(grep -E 'RESULT:|TESTS:|ERRORS:|FAILURES:' /results/live.log | sed 's/\x1b\[[0-9;]*m//g' | tr -s ' \n' ' ')"
# The offline tool on a simulated drive, for scripts/test_platform.sh to hold against this
# machine's build: the same digits where the libraries compute the same.
"${bin}/simulate_drive" --out /results/tool/drive --seed 4 --length 2000 --map-points 20000 \
  > /results/tool.log 2>&1 || rc=1
for run in defaults:fusion=true fusion_false:fusion=false; do
  "${bin}/georeference" --gnss /results/tool/drive/gnss.txt --poses \
    /results/tool/drive/slam_trajectory.txt --map /results/tool/drive/map.pcd --datum 48.262 \
    11.667 480 --set "${run#*:}" --set report_png=false -q --out "/results/tool/${run%%:*}" \
    >> /results/tool.log 2>&1 || rc=1
done
exit "${rc}"
