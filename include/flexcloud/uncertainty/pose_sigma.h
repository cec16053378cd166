#pragma once
// How far each pose of the result may lie from the truth: a 1-sigma per pose, horizontal (per
// axis) and vertical, from what the run knows. The correction the result applies to the rigidly
// aligned SLAM is taken as a random walk along the path, observed by the fixes the result rests
// on with their own std-devs; its walk's intensity is learned from those fixes by maximum
// likelihood, and a smoother's variance says how well the fixes pin the correction down at each
// pose (less between sparse fixes, least where they are dense, growing beyond the last one).
// What the fixes agree on but the truth may not (a multipath episode the result followed) shows
// in the local mean of the fixes' residuals from the result, which is added. The weights of the
// two are calibrated against the truth of real and simulated drives (doc/ACCURACY.md).

#include <cstddef>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

/// A fix the result rests on: its instant on the SLAM clock, ENU position, own 1-sigma
/// (horizontal per axis, vertical), m.
struct SigmaFix {
  double t = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double std_h = 0.0;
  double std_v = 0.0;
};

/// The longest run of poses around the least certain one whose horizontal sigma is at least
/// half of its: stamps (SLAM clock) and the largest sigma there.
struct SigmaStretch {
  double from = 0.0;
  double to = 0.0;
  double sigma_h = 0.0;
};

struct PoseSigmas {
  std::vector<double> h;  ///< per pose: 1-sigma per horizontal axis, m (the 95 % circle: 2.45 h)
  std::vector<double> v;  ///< per pose: 1-sigma vertical, m (95 %: 1.96 v)
  double median_h = 0.0;
  double p95_h = 0.0;
  double median_v = 0.0;
  SigmaStretch worst;
  /// The correction's random walk as learned from the fixes, m^2 per m of path.
  double walk_h = 0.0;
  double walk_v = 0.0;
  std::size_t fixes = 0;  ///< fixes it rests on
};

/// The sigmas of `result` (ENU, SLAM clock), whose rigid part is `aligned` (the same poses
/// transformed rigidly), from the fixes it rests on. Without fixes every sigma is infinite.
PoseSigmas poseSigmas(const Trajectory& result, const Trajectory& aligned,
                      std::vector<SigmaFix> fixes);

}  // namespace flexcloud
