#include "flexcloud/sim/truth_metrics.h"

#include <algorithm>
#include <cmath>

namespace flexcloud::sim {

MapTruthErrors mapTruthErrors(const SimMap& map,
                              const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& warp) {
  ErrorAccumulator all, near, mid, far;
  for (std::size_t i = 0; i < map.slam.size(); ++i) {
    // The SLAM map is stored in float32, as a SLAM system writes it.
    const Eigen::Vector3d p = map.slam[i].cast<float>().cast<double>();
    const double e = (warp(p) - map.truth[i]).norm();
    all.add(e);
    const float d = map.lateral[i];
    (d < 5.0f ? near : d < 15.0f ? mid : far).add(e);
  }
  return {all.stats(), near.stats(), mid.stats(), far.stats()};
}

MapTruthErrors mapTruthErrors(const SimMap& map, const RubberSheet& sheet) {
  return mapTruthErrors(map, [&](const Eigen::Vector3d& p) { return sheet.transform(p); });
}

ErrorStats trajectoryTruthError(const Trajectory& estimate, const Trajectory& truth) {
  ErrorAccumulator acc;
  for (std::size_t i = 0; i < estimate.size() && i < truth.size(); ++i) {
    acc.add((estimate[i].position - truth[i].position).norm());
  }
  return acc.stats();
}

namespace {

/// The first lag (in samples) at which the autocorrelation of `z` (its mean taken out) falls
/// below 1/e; at least 1, at most half the series.
double decorrelationLag(const std::vector<double>& z) {
  const auto n = z.size();
  if (n < 4) return 1.0;
  double mean = 0.0;
  for (double x : z) mean += x;
  mean /= static_cast<double>(n);
  double var = 0.0;
  for (double x : z) var += (x - mean) * (x - mean);
  if (!(var > 0.0)) return 1.0;
  for (std::size_t lag = 1; lag < n / 2; ++lag) {
    double c = 0.0;
    for (std::size_t i = 0; i + lag < n; ++i) c += (z[i] - mean) * (z[i + lag] - mean);
    const double r = c / static_cast<double>(n - lag) / (var / static_cast<double>(n));
    if (r < std::exp(-1.0)) return static_cast<double>(lag);
  }
  return static_cast<double>(n / 2);
}

}  // namespace

SigmaCoverage& SigmaCoverage::operator+=(const SigmaCoverage& o) {
  poses += o.poses, within_h += o.within_h, within_v += o.within_v;
  independent_h += o.independent_h, independent_v += o.independent_v;
  return *this;
}

SigmaCoverage sigmaCoverage(const std::vector<Eigen::Vector3d>& errors,
                            const std::vector<double>& sigma_h,
                            const std::vector<double>& sigma_v) {
  SigmaCoverage c;
  std::vector<double> zx, zy, zv;
  for (std::size_t i = 0; i < errors.size() && i < sigma_h.size() && i < sigma_v.size(); ++i) {
    const Eigen::Vector3d& e = errors[i];
    c.poses += 1.0;
    c.within_h += e.head<2>().norm() <= 2.45 * sigma_h[i];
    c.within_v += std::abs(e.z()) <= 1.96 * sigma_v[i];
    zx.push_back(e.x() / sigma_h[i]);
    zy.push_back(e.y() / sigma_h[i]);
    zv.push_back(e.z() / sigma_v[i]);
  }
  const double lag_h = 0.5 * (decorrelationLag(zx) + decorrelationLag(zy));
  c.independent_h = c.poses / lag_h;
  c.independent_v = c.poses / decorrelationLag(zv);
  return c;
}

CoverageBand calibratedBand(double independent) {
  constexpr double kShare = 0.95, kTwoSided99 = 2.576;
  if (!(independent > 0.0)) return {};
  const double half = kTwoSided99 * std::sqrt(kShare * (1.0 - kShare) / independent);
  return {std::max(0.0, kShare - half), std::min(1.0, kShare + half)};
}

}  // namespace flexcloud::sim
