#pragma once
// Keyframe interpolation: the GNSS position at each SLAM pose stamp.

#include <optional>
#include <vector>

#include "flexcloud/params.h"
#include "flexcloud/types.h"

namespace flexcloud {

/// The GNSS at each stamp, or nothing where the stamp lies outside the GNSS time span or inside
/// a gap longer than params.max_gap. gnss must be sorted by stamp with unique stamps.
/// Spline mode: the cubic through four GNSS points, the two nearest before and after the stamp,
/// the outer two at least params.min_spacing metres from the inner ones (fewer points near the
/// ends of the data). The std-dev is sum |w_i| * std_i over the interpolation weights w_i.
/// Nearest mode: the GNSS point nearest in time, if within max_gap / 2.
std::vector<std::optional<GnssPoint>> interpolateGnss(const std::vector<GnssPoint>& gnss,
                                                      const std::vector<double>& stamps,
                                                      const Params& params);

}  // namespace flexcloud
