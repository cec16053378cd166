#pragma once
// The simulated SLAM trajectory: the true motion with the drift of SimParams, the failures of
// SlamErrors and the loop closures. Private to the simulator.

#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "flexcloud/sim/drive_simulator.h"

namespace flexcloud::sim {

/// The SLAM poses (its map frame, starting at the identity) of the true poses `truth` at the
/// driven arc lengths `arc`.
std::vector<Eigen::Isometry3d> integrateSlam(const std::vector<Eigen::Isometry3d>& truth,
                                             const std::vector<double>& arc, const SimParams& p,
                                             std::mt19937_64& rng);

/// The poses a keyframe SLAM keeps of those at `arc` (all of them when the keyframe spacing is
/// 0): the first, then one each time the path since the last reaches a spacing drawn in
/// [keyframe_min_m, keyframe_max_m], and the last.
std::vector<std::size_t> keyframeIndices(const std::vector<double>& arc, const SlamErrors& e,
                                         std::uint64_t seed);

}  // namespace flexcloud::sim
