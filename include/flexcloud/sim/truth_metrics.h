#pragma once
// Errors against the simulator's ground truth: the map (all points and by distance from the
// route) and the trajectory. The tests and the accuracy study judge every result by these.

#include <functional>
#include <vector>

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

/// How a result's pose sigmas hold against the truth: how many poses lie within the 95 % circle
/// (2.45 sigma_h) and within 1.96 sigma_v, and how many independent samples the poses amount
/// to. The errors in sigmas stay alike over stretches (a multipath episode, a drift the result
/// kept): one pose counts for 1 / the lag at which their autocorrelation falls below 1/e.
struct SigmaCoverage {
  double poses = 0.0, within_h = 0.0, within_v = 0.0;
  double independent_h = 0.0, independent_v = 0.0;
  double shareH() const { return poses > 0.0 ? within_h / poses : 0.0; }
  double shareV() const { return poses > 0.0 ? within_v / poses : 0.0; }
  /// Pooled with another drive's.
  SigmaCoverage& operator+=(const SigmaCoverage& o);
};

/// The coverage of `errors` (estimate minus truth, per pose) by the 1-sigmas `sigma_h` (per
/// horizontal axis) and `sigma_v`.
SigmaCoverage sigmaCoverage(const std::vector<Eigen::Vector3d>& errors,
                            const std::vector<double>& sigma_h, const std::vector<double>& sigma_v);

/// The shares of a 95 % region that calibrated sigmas show on `independent` samples, in all but
/// 1 % of drives (binomial, normal approximation): 0.95 -+ 2.58 sqrt(0.95 * 0.05 / independent),
/// within [0, 1].
struct CoverageBand {
  double low = 0.0, high = 1.0;
};
CoverageBand calibratedBand(double independent);

}  // namespace flexcloud::sim
