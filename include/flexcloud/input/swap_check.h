#pragma once
// Latitude and longitude swapped in the input (a GNSS text file with its columns the other way
// round): the fixes then draw the drive mirrored and stretched, which no rigid fit of the
// SLAM's track can follow.

#include <optional>
#include <vector>

#include "flexcloud/input/gnss.h"
#include "flexcloud/input/interpolation.h"
#include "flexcloud/types.h"

namespace flexcloud {

/// The median distance (m) of the GNSS at the poses from the poses rigidly fitted to it;
/// NaN with fewer than 3 pairs.
double rigidFitMedian(const Trajectory& poses, const std::vector<std::optional<GnssPoint>>& at);

/// Throws Error "GNSS: latitude and longitude look swapped: ..." where the fixes lie more than
/// 10 m (median) off the SLAM's track rigidly fitted to them as given, and at least five times
/// nearer with latitude and longitude swapped. `given_median` is rigidFitMedian() of the run's
/// GNSS at the poses; the check costs nothing more where it is 10 m or less.
void checkLatLonOrder(const std::vector<RawFix>& fixes, const Trajectory& poses,
                      double given_median, GnssOptions gnss, const InterpolationOptions& at);

}  // namespace flexcloud
