#!/usr/bin/env bash
# Runs a command inside the built workspace's ROS environment, from any folder, e.g.
#   scripts/env.sh roslaunch flexcloud georeference.launch bag:=/data/drive.bag
#   scripts/env.sh rosrun flexcloud georeference --help
# Builds the workspace first if it has not been built yet.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
if [ ! -f "${FLEXCLOUD_WS}/devel/setup.bash" ]; then
  install_deps
  build_workspace
fi
if [ "$#" -eq 0 ]; then
  echo "usage: scripts/env.sh COMMAND [ARGS...]" >&2
  exit 2
fi
in_workspace "$@"
