#!/usr/bin/env bash
# Builds the package into a git-ignored catkin workspace (.ws/ in the repository) and reuses it
# on the next run. Usage: scripts/build.sh [extra catkin_make/CMake arguments]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
build_workspace "$@"
