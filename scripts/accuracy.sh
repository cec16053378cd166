#!/usr/bin/env bash
# Runs the accuracy study of doc/ACCURACY.md: simulated drives (RTK and urban GNSS, loop and open
# route, several seeds) georeferenced by the published method and by flexcloud, judged against
# the simulator's ground truth.
#   scripts/accuracy.sh [flexcloud_accuracy options, e.g. --seeds 1,2 --scenarios open_urban]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
install_deps
build_workspace
exec "${FLEXCLOUD_WS}/devel/lib/flexcloud/flexcloud_accuracy" "$@"
