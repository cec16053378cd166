#!/usr/bin/env bash
# Runs the benchmark (doc/BENCHMARKS.md): warp, PCD I/O, the whole tool, peak memory.
#   scripts/benchmark.sh [flexcloud_benchmark options, e.g. --points 1000000 --repeat 5]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
install_deps
build_workspace
real=()
a2rl="${FLEXCLOUD_ROOT}/../shared/data/a2rl"
[ -f "${a2rl}/slam_poses_tum.txt" ] && real=(--real "${a2rl}")
exec "${FLEXCLOUD_WS}/devel/lib/flexcloud/flexcloud_benchmark" "${real[@]}" "$@"
