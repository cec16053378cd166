#!/usr/bin/env bash
# Runs the benchmark (doc/BENCHMARKS.md): warp, PCD I/O, the whole tool, peak memory.
#   scripts/benchmark.sh [flexcloud_benchmark options, e.g. --points 1000000 --repeat 5]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
install_deps
build_workspace
exec "${FLEXCLOUD_WS}/devel/lib/flexcloud/flexcloud_benchmark" "$@"
