#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

/// The GNSS clock offset seen in the speed profiles (GNSS time - SLAM time, negated: the fix
/// stamped t is the pose at t + offset, the sign FusionResult::time_offset uses).
struct ClockOffsetEstimate {
  bool observable = false;  ///< false: the speed varies too little to show an offset
  double offset = 0.0;      ///< s
  double sigma = 0.0;       ///< s, 1-sigma (infinite where not observable)
  std::size_t samples = 0;  ///< speed samples compared
};

/// Compares the speed of the SLAM with the GNSS's over a grid of offsets within +-max_offset.
/// Speed does not depend on the orientation, so the SLAM's rotation drift (heading or pitch)
/// cannot mimic an offset the way it can in a fit of positions; only changes of the speed
/// (stops, braking) show the offset.
ClockOffsetEstimate estimateClockOffset(const Trajectory& poses, const std::vector<GnssPoint>& gnss,
                                        double max_offset);

/// The same offset from the headings: the course of the GNSS against the course of the SLAM's
/// antenna (lever_arm in the body frame) at the offset, less their slowly changing difference
/// (the SLAM's frame and its heading drift, a moving median over 20 s), against the SLAM's turn
/// rate (Tukey's biweight), from `start` (s) in rounds until it settles; its sigma at least the
/// spread of the offsets of four stretches of the drive. No scale or speed error of the SLAM
/// enters it; only turns show the offset. None from fixes sparser than 2 Hz, whose course is
/// a chord.
ClockOffsetEstimate estimateHeadingOffset(const Trajectory& poses, const Eigen::Vector3d& lever_arm,
                                          const std::vector<GnssPoint>& gnss, double start);

/// s, what a real SLAM's lag in its speed or heading adds to either profile's offset (KITTI's
/// LiDAR odometry against its truth: up to 5 ms but on one drive of nine, 25 ms in both).
constexpr double kClockSystematic = 0.005;
/// An offset is applied only beyond this many of its sigmas from 0. At 3, urban GNSS at 1 Hz
/// (KITTI 01, its poses' stamps shifted by -0.3 s: the speed profiles -0.27 +- 0.09 s) kept
/// the stamps as given, 0.3 s off.
constexpr double kClockSignificant = 2.0;
/// s: how far a real SLAM's own lag may move both profiles where the clocks agree (KITTI 03:
/// 23 ms in the speed, 28 in the heading, 17 in the fit of positions; its true offset is 0). An
/// offset is applied only beyond kClockSignificant times its sigma and this together (at least
/// 27 ms with kClockSystematic in the sigma): below, the profiles cannot tell a clock from such a
/// lag, and the stamps as given were the closer to the truth (03 RTK: 0.025 against 0.129 m with
/// the 17 ms applied).
constexpr double kSlamLag = 0.0125;

/// Whether an offset with this 1-sigma is told from a SLAM's own lag: beyond `k` times its
/// sigma and kSlamLag together.
bool beyondSlamLag(double offset, double sigma, double k);

/// s: profiles whose 1-sigma passes this know the offset too loosely for the stamps as given to
/// be the better guess, told from 0 or not (0.5 m along the track at 20 m/s): the fit of
/// positions decides it within their sigma. KITTI with 1 Hz urban GNSS, its poses' stamps 0.1 s
/// off: the profiles 0.12 +- 0.09 s on 01, 71 +- 34 ms on 02; held at 0, 2.4 and 1.1 m RMSE
/// against the truth, fitted 0.17 and 0.41 m.
constexpr double kLooseClock = 0.025;
/// m/s: a drive whose horizontal velocity spreads by less across its main direction (the
/// smaller axis of the velocities' covariance) is a straight, where an offset moves every fix
/// as a shift does and the fit of positions cannot tell them apart (KITTI 04, 0.13 m/s, its
/// stamps 0.1 s off: fitted 47 +- 6 ms, the SLAM's shape taken for it; the urban KITTI drives
/// 1.1-6.4 m/s).
constexpr double kLeastTurn = 1.0;

/// The two profiles together; none without the speed's.
struct ClockEstimate {
  ClockOffsetEstimate speed, heading;
  /// Their mean weighted by their sigmas; its 1-sigma widened to half their difference where
  /// they part by more than two of their joint sigmas (disagree), and by kClockSystematic.
  double offset = 0.0;
  double sigma = std::numeric_limits<double>::infinity();
  bool disagree = false;
  /// Whether it is told from 0 and from a SLAM's own lag (beyondSlamLag); otherwise the stamps
  /// as given are the better guess, and `reason` says why.
  bool observable = false;
  /// Told from 0 but not from a SLAM's own lag: worth a word (27 ms is 0.27 m along the track
  /// at 10 m/s, should the clock be off after all).
  bool within_lag = false;
  /// Not observable, but known too loosely (kLooseClock) for the stamps as given to be the
  /// better guess: the fusion lets its fit of positions decide it within the sigma where the
  /// drive turns (`reason` then empty and `observable` set).
  bool loose = false;
  std::string reason;
};

ClockEstimate combineClock(const ClockOffsetEstimate& speed, const ClockOffsetEstimate& heading);

/// Where a fit of positions took the offset (`fitted`, s) more than two of the speed profiles'
/// sigmas from theirs, the offset to hold the clock at instead: theirs where it lies beyond
/// three of their sigmas of 0, else 0 (the stamps as given are the better guess for an offset
/// within the noise). None where they agree or the profiles show nothing. A SLAM shape error
/// (fast turns) passes for an offset in a fit of positions, never in the speed profiles: on
/// monza the fit gives -0.0119 s, the profiles -0.0032 +- 0.0029 s, its rows one instant.
std::optional<double> heldClockOffset(double fitted, const ClockOffsetEstimate& speeds);

}  // namespace flexcloud
