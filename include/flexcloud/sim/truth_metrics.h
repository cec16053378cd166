#pragma once
// Errors against the simulator's ground truth: the map (all points and by distance from the
// route) and the trajectory. The tests and the accuracy study judge every result by these.

#include <functional>

#include "flexcloud/metrics.h"
#include "flexcloud/sheet/rubber_sheet.h"
#include "flexcloud/sim/drive_simulator.h"

namespace flexcloud::sim {

/// Map error (m) of all points and by horizontal distance from the route's centre line.
struct MapTruthErrors {
  ErrorStats all;
  ErrorStats near;  ///< 0-5 m from the route
  ErrorStats mid;   ///< 5-15 m
  ErrorStats far;   ///< 15-30 m
};

/// The error of every SLAM map point moved by `warp` (map frame -> ENU) against its truth.
MapTruthErrors mapTruthErrors(const SimMap& map,
                              const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& warp);
/// The same for the rubber sheet of a result.
MapTruthErrors mapTruthErrors(const SimMap& map, const RubberSheet& sheet);

/// Position error (m) of a trajectory against the true one (same stamps, same order).
ErrorStats trajectoryTruthError(const Trajectory& estimate, const Trajectory& truth);

}  // namespace flexcloud::sim
