#pragma once
// Keyframe interpolation: the GNSS position at each SLAM pose stamp.

#include <optional>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

/// The numbers keyframe interpolation uses; interpolationOptions() (params.h) fills them from
/// the parameter table.
struct InterpolationOptions {
  InterpolationMode mode = InterpolationMode::kSpline;
  double min_spacing = 0.0;  ///< m between the spline's support points
  double max_gap = 0.0;      ///< s, the longest GNSS gap interpolated across
};

/// The GNSS at each stamp, or nothing where the stamp lies outside the GNSS time span or inside
/// a gap longer than options.max_gap. gnss must be sorted by stamp with unique stamps.
/// Spline mode: the cubic through four GNSS points, the two nearest before and after the stamp,
/// the outer two at least options.min_spacing metres from the inner ones (fewer points near the
/// ends of the data). The std-dev is sum |w_i| * std_i over the interpolation weights w_i.
/// Nearest mode: the GNSS point nearest in time, if within max_gap / 2.
std::vector<std::optional<GnssPoint>> interpolateGnss(const std::vector<GnssPoint>& gnss,
                                                      const std::vector<double>& stamps,
                                                      const InterpolationOptions& options);

}  // namespace flexcloud
