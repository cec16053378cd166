#include "flexcloud/uncertainty/map_sigma.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "flexcloud/metrics.h"

namespace flexcloud {
namespace {

constexpr std::size_t kSampledPoses = 1000;
constexpr int kPerBand = 4;  // distances a band, each side

/// The value at share q (0..1) of the sorted values; NaN for none.
double quantileOf(std::vector<double>& v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

/// The root mean square of the values; NaN for none.
double rms(const std::vector<double>& v) {
  return v.empty() ? std::numeric_limits<double>::quiet_NaN() : errorStats(v).rmse;
}

/// The sigmas of a band's points.
struct BandSamples {
  std::vector<double> h, v;

  void add(const PointSigma& s) {
    if (!std::isfinite(s.h)) return;
    h.push_back(s.h), v.push_back(s.v);
  }
  MapSigmaBand summary() { return {rms(h), quantileOf(h, 0.5), quantileOf(h, 0.95), rms(v)}; }
};

}  // namespace

MapSigma expectedMapSigma(const Trajectory& slam, const Trajectory& result,
                          const PoseSigmas& sigmas, const RubberSheet& sheet,
                          const PointSigmaModel& model) {
  const PointSigmaField field(result, sigmas, sheet, model);
  const BodyAxes axes = bodyAxes(slam);
  const std::size_t stride = std::max<std::size_t>(1, slam.size() / kSampledPoses);
  std::array<BandSamples, kMapSigmaBands> by_sheet, by_pose;
  int hint = 0;
  for (std::size_t i = 0; i < slam.size(); i += stride) {
    const Eigen::Isometry3d s = isometryOf(slam[i]);
    const Eigen::Isometry3d own = isometryOf(result[i]) * s.inverse();
    for (int b = 0; b < kMapSigmaBands; ++b) {
      const double from = kMapSigmaBandEdges[b], to = kMapSigmaBandEdges[b + 1];
      for (int k = 0; k < kPerBand; ++k) {
        const double r = from + (to - from) * (k + 0.5) / kPerBand;
        for (const double side : {-1.0, 1.0}) {
          const Eigen::Vector3d q = s * Eigen::Vector3d(side * r * axes.left);
          const RubberSheet::Location loc = sheet.locateFrom(q, hint);
          if (!loc.outside) hint = loc.tet;
          const Eigen::Vector3d enu = RubberSheet::apply(sheet.affineAt(loc), q);
          by_sheet[b].add(field.at(enu, loc.outside ? -1 : loc.tet));
          by_pose[b].add(field.ofPose(own * q, static_cast<int>(i)));
        }
      }
    }
  }
  MapSigma out{};
  for (int b = 0; b < kMapSigmaBands; ++b) {
    out.sheet[b] = by_sheet[b].summary();
    out.own_pose[b] = by_pose[b].summary();
  }
  return out;
}

}  // namespace flexcloud
