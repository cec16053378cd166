#include "flexcloud/slam_jitter.h"

#include <algorithm>
#include <cmath>

#include "flexcloud/metrics.h"

namespace flexcloud {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr double kClearExcess = 1.5;  // the residuals' spread must pass the GNSS's by this

/// |third difference| of a series from j on, per axis.
std::vector<Vec3> thirdDifferences(const std::vector<Vec3>& x) {
  std::vector<Vec3> d;
  for (std::size_t j = 0; j + 3 < x.size(); ++j) {
    d.push_back((x[j + 3] - 3.0 * x[j + 2] + 3.0 * x[j + 1] - x[j]).cwiseAbs());
  }
  return d;
}

/// White-noise 1-sigma, horizontal (x and y pooled) and vertical, from the |third
/// differences| d[lo, hi) (see roughness()).
Eigen::Vector2d spread(const std::vector<Vec3>& d, std::size_t lo, std::size_t hi) {
  std::vector<double> h, v;
  for (std::size_t j = lo; j < hi; ++j) {
    h.push_back(d[j].x());
    h.push_back(d[j].y());
    v.push_back(d[j].z());
  }
  return Eigen::Vector2d(median(h), median(v)) / 3.016;
}

double excess(double residual, double gnss, double floor) {
  const double g = kClearExcess * std::max(gnss, floor);
  return residual > g ? std::sqrt(residual * residual - g * g) : 0.0;
}

}  // namespace

Eigen::Vector2d roughness(const std::vector<Vec3>& track) {
  const std::vector<Vec3> d = thirdDifferences(track);
  return spread(d, 0, d.size());
}

std::vector<Vec3> slamJitter(const std::vector<Vec3>& fixes, const std::vector<Vec3>& slam,
                             int window, double floor) {
  std::vector<Vec3> out(fixes.size(), Vec3::Zero());
  const std::size_t w = static_cast<std::size_t>(std::max(2, window));
  if (fixes.size() < w + 3) return out;
  std::vector<Vec3> residual(fixes.size());
  for (std::size_t j = 0; j < fixes.size(); ++j) residual[j] = fixes[j] - slam[j];
  const std::vector<Vec3> dg = thirdDifferences(fixes), dr = thirdDifferences(residual);
  for (std::size_t j = 0; j < fixes.size(); ++j) {
    // The window [lo, hi) of third differences around fix j, full length at the ends too.
    const std::size_t lo = std::min(j > w ? j - w : 0, dg.size() - std::min(dg.size(), 2 * w));
    const std::size_t hi = std::min(dg.size(), lo + 2 * w);
    const Eigen::Vector2d g = spread(dg, lo, hi), r = spread(dr, lo, hi);
    const double h = excess(r.x(), g.x(), floor);
    out[j] = Vec3(h, h, excess(r.y(), g.y(), floor));
  }
  return out;
}

}  // namespace flexcloud
