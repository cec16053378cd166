#pragma once
// The precise fixes' residuals from the keyframe graph's trajectory, as the refinement by
// precise fixes (precise_follow.h) takes them: gathered, kept where they are as smooth as they
// claim, and the steps where the SLAM jumped. Private to the core.

#include <cstddef>
#include <vector>

#include "flexcloud/fusion/fusion.h"
#include "flexcloud/fusion/precise_follow.h"

namespace flexcloud {
namespace follow {

using Vec3 = Eigen::Vector3d;

/// Fixes on either side of each that its white noise is read over (Series::noise, the
/// smoothness check of keepTheSmooth()).
constexpr std::size_t kNoiseReach = 10;

/// The fixes that take part, in instant order: residual from the fused antenna, own variance,
/// instant, the path to it (time_metres per second added), the std-dev claimed, the input
/// index.
struct Series {
  std::vector<Vec3> r, var;
  std::vector<double> t, along;
  /// The horizontal std-dev each fix came with (NaN where the fusion estimated it).
  std::vector<double> claim;
  /// Whether a fix that claimed less than max_std (a float solution, a receiver that knows it
  /// is off) lies between it and the fix before it in the series: the receiver's status changed.
  std::vector<bool> doubt;
  /// The white noise the fixes' positions show around each (m per horizontal axis, from their
  /// third differences, the motion's jerk in it; NaN where keepTheSmooth() did not measure it).
  std::vector<double> noise;
  std::vector<std::size_t> fix;
  std::size_t size() const { return t.size(); }
  /// Path from the fix before to fix j (0 for the first).
  double step(std::size_t j) const { return j == 0 ? 0.0 : along[j] - along[j - 1]; }
  void add(const Series& from, std::size_t j);
};

/// The fused pose at instant t (within the poses' span; k is the search's start, kept between
/// calls with rising t): positions linear, orientations slerp.
Pose poseAt(const Trajectory& poses, double t, std::size_t& k);

/// The std-dev a fix counts with in the refinement: its own, or the white noise of fixes
/// without one (FusionResult::unknown_white).
Vec3 ownStd(const FusionResult& f, const FixOutcome& x);

/// The fixes the fusion judged (used or outlier) within the poses' span whose own horizontal
/// std-dev is within max_std; a fix without a std-dev counts with the white noise of such
/// fixes (FusionResult::unknown_white), not the fusion's estimate, which holds what the
/// keyframe graph could not follow of the SLAM.
Series gather(const FusionResult& f, const FollowOptions& o);

/// Keeps the fixes as smooth as their std-devs claim: around each, the white noise of the ten
/// fixes on either side within twice its own horizontal std-dev. The noise is read twice, from
/// the fixes' positions (the motion's jerk adds to it) and from their residuals (the SLAM's
/// jitter adds to it), and the smaller taken. A multipath episode whose fixes claim RTK
/// precision while they scatter by decimetres fails; a lone outlier or a jump of the SLAM moves
/// a few differences and not their median.
Series keepTheSmooth(const Series& s, const std::vector<Vec3>& positions);

/// Steps where the SLAM jumped (1, else 0), from the residuals alone: the five fixes before a
/// step and the five after it each agree among themselves (their spread about their median
/// within three of their own std-devs on every axis), and their medians part by more than eight
/// of that spread. An outlier moves no median; a ramp of the GNSS (multipath setting in) or a
/// fix that is rougher than it claims fails the agreement.
std::vector<double> detectJumps(const Series& s);

/// The 1-sigma spread of values around their median (1.4826 MAD).
double madSigma(std::vector<double> v);

}  // namespace follow
}  // namespace flexcloud
