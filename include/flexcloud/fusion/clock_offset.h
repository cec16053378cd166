#pragma once

#include <optional>
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

/// Where a fit of positions took the offset (`fitted`, s) more than two of the speed profiles'
/// sigmas from theirs, the offset to hold the clock at instead: theirs where it lies beyond
/// three of their sigmas of 0, else 0 (the stamps as given are the better guess for an offset
/// within the noise). None where they agree or the profiles show nothing. A SLAM shape error
/// (fast turns) passes for an offset in a fit of positions, never in the speed profiles: on
/// monza the fit gives -0.0119 s, the profiles -0.0032 +- 0.0029 s, its rows one instant.
std::optional<double> heldClockOffset(double fitted, const ClockOffsetEstimate& speeds);

}  // namespace flexcloud
