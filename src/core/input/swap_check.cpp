#include "flexcloud/input/swap_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "flexcloud/sheet/alignment.h"

namespace flexcloud {

double rigidFitMedian(const Trajectory& poses, const std::vector<std::optional<GnssPoint>>& at) {
  std::vector<Eigen::Vector3d> src, dst;
  for (std::size_t i = 0; i < poses.size() && i < at.size(); ++i) {
    if (!at[i]) continue;
    src.push_back(poses[i].position);
    dst.push_back(at[i]->position);
  }
  if (src.size() < 3) return std::nan("");
  Eigen::Isometry3d T;
  try {
    T = umeyama(src, dst, {}, false).rigid();
  } catch (const Error&) {
    return std::nan("");  // all in one place: nothing to tell
  }
  std::vector<double> d(src.size());
  for (std::size_t i = 0; i < src.size(); ++i) d[i] = (T * src[i] - dst[i]).norm();
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

void checkLatLonOrder(const std::vector<RawFix>& fixes, const Trajectory& poses,
                      double given_median, GnssOptions gnss, const InterpolationOptions& at) {
  constexpr double kFar = 10.0;    // m: beyond any SLAM's drift over a drive's rigid fit
  constexpr double kBetter = 5.0;  // times nearer with the two swapped
  if (!(given_median > kFar)) return;
  std::vector<RawFix> swapped = fixes;
  for (RawFix& f : swapped) {
    if (f.has_fix && std::abs(f.fix.lon) > 90.0) return;  // no latitude: not swapped
    std::swap(f.fix.lat, f.fix.lon);
  }
  gnss.datum.reset();  // the datum given is of the fixes as given
  double median = std::nan("");
  try {
    const PreparedGnss prepared = prepareGeodeticGnss(swapped, gnss);
    std::vector<double> stamps;
    for (const Pose& p : poses) stamps.push_back(p.stamp);
    median = rigidFitMedian(poses, interpolateGnss(prepared.points, stamps, at));
  } catch (const Error&) {
    return;  // the swapped fixes are no drive either
  }
  if (!(median * kBetter < given_median)) return;
  char line[320];
  std::snprintf(line, sizeof(line),
                "GNSS: latitude and longitude look swapped: the SLAM's track fits the fixes to "
                "%.1f m (median) as given and to %.2f m with the two swapped (the first fix "
                "reads latitude %.6f, longitude %.6f); give them as latitude, longitude",
                given_median, median, swapped.front().fix.lon, swapped.front().fix.lat);
  throw Error(line);
}

}  // namespace flexcloud
