#pragma once
// A SLAM's white jitter from pose to pose: scan matching puts every pose a centimetre or two off
// a smooth path, each by an error of its own (KITTI's LiDAR odometry: 1.1-2.0 cm per axis at
// 10 Hz, its truth 0.1-0.2 cm). No smooth correction (the fusion's, the sheet's) takes it out;
// the vehicle's own path is smooth over a second, so a local cubic in time does.

#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

/// What the poses show of their jitter, and the smoothing it calls for.
struct JitterSmoothing {
  double white = 0.0;   ///< m, 1-sigma per horizontal axis of the poses' white jitter
  double motion = 0.0;  ///< m, what the motion's jerk puts into the same third differences
  /// The share of the poses' roughness that is their own, not the GNSS's at the same instants
  /// too (ownJitterShare; 1 where that cannot be told).
  double own_share = 1.0;
  /// The jitter makes up at least three quarters of the differences' variance and 1 cm, and at
  /// least three quarters of it is the poses' own: `white` is their error, smoothed or not.
  bool seen = false;
  /// Poses either side of each in its local cubic, chosen by leave-one-out cross-validation;
  /// 0: none smoothed (no jitter beyond the motion, or too few poses within kMostSpan).
  int half_width = 0;
};

/// s: the longest span of poses a local cubic goes over.
constexpr double kMostSpan = 1.0;

/// The jitter of `poses` (sorted by stamp). Third divided differences hold position, speed and
/// acceleration out: at the poses' spacing they hold the white jitter and the jerk times the
/// spacing cubed; of every second pose the same jitter and eight times that (64 in variance),
/// which tells the two apart. Smoothed only where it is `seen`. `poses` in ENU with `fixes` for
/// ownJitterShare; none: the jitter taken as the poses' own.
JitterSmoothing measureJitter(const Trajectory& poses, const std::vector<GnssPoint>& fixes = {});

/// How much of the poses' white jitter (`white`, m) is theirs alone, from the fixes stamped as a
/// pose is (`fixes`, ENU; the others are left out): such a fix shares what is the vehicle's or
/// the stamps' (fixes resampled at the poses' stamps, or stamps made up after the fact, move
/// poses and fixes along the track alike), and the residuals (fix less pose) hold what is
/// either's own. Over the poses with a fix, own^2 = (residual^2 + poses^2 - fixes^2) / 2
/// (roughness()), over white^2, within [0, 1]. 1 where it cannot be told: fewer than 8 such poses,
/// or fixes rougher than three times `white` (1 Hz urban GNSS: its noise and the motion between its
/// fixes drown a jitter of centimetres).
double ownJitterShare(const Trajectory& aligned, const std::vector<GnssPoint>& fixes, double white);

/// `t`'s positions, each the local cubic in time through the 2 `half_width` + 1 poses around
/// it (shifted to stay within the trajectory, narrowed to kMostSpan, five to 17 poses);
/// orientations stay. Poses with `keep[i]` set (a SLAM jump next to them) stay as they are
/// and no window spans them. `t` sorted by stamp. Returns per pose the share of white jitter
/// left in its position (the norm of its cubic's weights; 1 where it stays as it was).
std::vector<double> smoothJitter(Trajectory& t, int half_width, const std::vector<bool>& keep = {});

}  // namespace flexcloud
