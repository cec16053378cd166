#pragma once
// Revisits: control points of different passes over the same place (within 5 m of each other
// after the alignment, more than 50 m of path apart). Private to the core.

#include <optional>
#include <vector>

#include "flexcloud/georeference.h"

namespace flexcloud {

/// Compares, for each revisit pair, the offset between the two control points' targets (the
/// fused trajectory, or the GNSS without fusion) with their aligned SLAM offset: a conflict
/// there means the SLAM map holds the place twice (an unclosed loop). With `gnss` (the raw
/// GNSS at the poses), also counts the pairs where the GNSS disagrees with a SLAM that the
/// targets confirm: the GNSS was wrong there and was outvoted.
RevisitCheck checkRevisits(const ControlPointSelection& cps, const Trajectory& poses,
                           const Eigen::Isometry3d& T_enu_map,
                           const std::vector<std::optional<GnssPoint>>& gnss);

}  // namespace flexcloud
