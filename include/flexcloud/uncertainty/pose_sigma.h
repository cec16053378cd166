#pragma once
// How far each pose of the result may lie from the truth: a 1-sigma per pose, horizontal (per
// axis) and vertical, from what the run knows. The correction the result applies to the rigidly
// aligned SLAM is taken as a walk along the path (its value and its rate wander: the SLAM's
// drift jitters and bends), observed by the fixes the result rests on with their own std-devs.
// The walk's intensities are learned from those fixes by maximum likelihood, and a smoother's
// variance says how well the fixes pin the correction down at each pose: least where they are
// dense, more between sparse ones, growing beyond the last. Added to it: the local mean of the
// fixes' residuals from the result (what the fixes agree on but the truth may not, as a multipath
// episode the result followed; horizontally less what their own noise puts into it; a disputed
// stretch of rejected fixes counts there too), what the sheet left of the fused trajectory, and
// the speed times an estimated clock offset's sigma. What the fixes pin down is never taken
// below the error they share: the part of a receiver's reported std-dev beyond the white noise
// the drive shows of it (a GNSS/INS's wander, which the result follows and no number of fixes
// averages out). The weights are calibrated against the truth of real and simulated drives
// (doc/ACCURACY.md).

#include <cstddef>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

/// A fix the result rests on: its instant on the SLAM clock, ENU position, own 1-sigma
/// (horizontal per axis, vertical), m, and the part of the std-dev its receiver reported that
/// its white noise leaves (0 where none was reported, or no more than the white noise): an
/// error that the neighbouring fixes share, which no number of them averages out. A `disputed`
/// fix was rejected, though it claimed RTK precision and agrees with its neighbours (the
/// GNSS's word against the SLAM's): the result does not rest on it, but how far the result lies
/// from it counts among the local residuals.
struct SigmaFix {
  double t = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double std_h = 0.0;
  double std_v = 0.0;
  double shared_h = 0.0;
  double shared_v = 0.0;
  bool disputed = false;
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
  /// The correction's walk as learned from the fixes: of its value, m^2 per m of path, and of
  /// its rate, m^2 per m^3 (random_walk.h).
  double walk_h = 0.0;
  double walk_v = 0.0;
  double walk_rate_h = 0.0;
  double walk_rate_v = 0.0;
  std::size_t fixes = 0;  ///< fixes it rests on
};

/// What else the run knows of the result.
struct SigmaContext {
  /// The fused trajectory the sheet was drawn through (the same poses; null: none): what the
  /// sheet left of it adds.
  const Trajectory* fused = nullptr;
  /// The 1-sigma of an estimated clock offset, s (0: none estimated): the speed times it moves
  /// a pose along the track.
  double clock_sigma = 0.0;
  /// Where the offset was held at the stamps as given (the profiles could not tell it from 0),
  /// the 1-sigma it is known to, s: it counts where the fixes are imprecise, whose noise hides
  /// the along-track error it makes (precise fixes show it in their local residuals).
  double held_clock_sigma = 0.0;
  /// The 1-sigma of an estimated antenna offset from the poses' origin along the track, m (0:
  /// none estimated): it trades with the clock offset, and moves every pose along the track.
  double antenna_sigma = 0.0;
  /// The GNSS antenna in the body frame, m: the fixes are the antenna's, the poses the body's.
  Eigen::Vector3d lever_arm = Eigen::Vector3d::Zero();
  /// The SLAM's white jitter from pose to pose, m per horizontal axis: in every fix's residual
  /// from the aligned SLAM beside the fix's own noise.
  double slam_white = 0.0;
  /// Per pose (null: none), m per horizontal axis: the SLAM's white jitter left in its position,
  /// which no smooth correction takes out.
  const std::vector<double>* jitter = nullptr;
};

/// The sigmas of `result` (ENU, SLAM clock), whose rigid part is `aligned` (the same poses
/// transformed rigidly), from the fixes it rests on. Without fixes every sigma is infinite.
PoseSigmas poseSigmas(const Trajectory& result, const Trajectory& aligned,
                      std::vector<SigmaFix> fixes, const SigmaContext& context = {});

}  // namespace flexcloud
