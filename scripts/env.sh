#!/usr/bin/env bash
# Runs a command inside the built workspace's ROS environment, from any folder, e.g.
#   scripts/env.sh roslaunch flexcloud georeference.launch bag:=/data/drive.bag
#   scripts/env.sh rosrun flexcloud georeference --help
# Installs and builds first if the workspace has not been built yet.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
usage_or_help "usage: scripts/env.sh COMMAND [ARGS...]   (runs COMMAND in flexcloud's built ROS workspace)" "${1:-}"
if [ ! -f "${FLEXCLOUD_WS}/devel/setup.bash" ]; then
  install_deps
  build_workspace
fi
link_package "${FLEXCLOUD_WS}"
in_workspace "$@"
