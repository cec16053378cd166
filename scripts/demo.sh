#!/usr/bin/env bash
# Installs what is missing, builds, simulates a 5 km drive with its ground truth, georeferences
# the drifted SLAM map with the drive's GNSS and prints what came out.
#   scripts/demo.sh [OUTPUT_FOLDER]        (default: out/demo in the repository)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
install_deps
build_workspace
out="${1:-${FLEXCLOUD_ROOT}/out/demo}"
mkdir -p "${out}"
out="$(cd "${out}" && pwd)"
bin="${FLEXCLOUD_WS}/devel/lib/flexcloud"

log "simulating a loop-closed 5 km drive with 1,000,000 map points"
"${bin}/simulate_drive" --out "${out}/drive" --map-points 1000000 --seed 1 \
  --fix-topic /gnss/fix --odom-topic /slam/odom
log "georeferencing it"
# The ground truth is in the ENU frame of the simulator's datum, so the run uses that datum.
"${bin}/georeference" --bag "${out}/drive/drive.bag" --map "${out}/drive/map.pcd" \
  --truth "${out}/drive/truth_map.pcd" --datum 48.2620 11.6670 480.0 \
  --control-points 200 --out "${out}/result" --quiet
echo
echo "The georeferenced map and its datum: ${out}/result/map_georeferenced.pcd, origin.yaml"
echo "Look at it in rviz: scripts/env.sh roslaunch flexcloud demo.launch drive:=${out}/drive"
