#include "flexcloud/fusion/slam_jitter.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "flexcloud/metrics.h"

namespace flexcloud {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr double kClearExcess = 1.5;  // the residuals' spread must pass the GNSS's by this

/// |third divided difference| of a series from j on, per axis, each divided by the norm of its
/// coefficients: white noise of 1-sigma s gives N(0, s^2) whatever the spacing of the stamps.
/// Four stamps that do not increase give no value (NaN).
std::vector<Vec3> thirdDifferences(const std::vector<Vec3>& x, const std::vector<double>& t) {
  std::vector<Vec3> d;
  for (std::size_t j = 0; j + 3 < x.size(); ++j) {
    const std::optional<Vec3> v = thirdDividedDifference(&x[j], &t[j]);
    d.push_back(v ? *v : Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  }
  return d;
}

/// White-noise 1-sigma, horizontal (x and y pooled) and vertical, from the normalised |third
/// differences| d[lo, hi) (see roughness()); the ones that could not be formed are skipped.
Eigen::Vector2d spread(const std::vector<Vec3>& d, std::size_t lo, std::size_t hi) {
  std::vector<double> h, v;
  for (std::size_t j = lo; j < hi; ++j) {
    if (!d[j].allFinite()) continue;
    h.push_back(d[j].x());
    h.push_back(d[j].y());
    v.push_back(d[j].z());
  }
  return Eigen::Vector2d(median(h), median(v)) / 0.6745;
}

double excess(double residual, double gnss, double floor) {
  const double g = kClearExcess * std::max(gnss, floor);
  return residual > g ? std::sqrt(residual * residual - g * g) : 0.0;
}

}  // namespace

std::optional<Vec3> thirdDividedDifference(const Vec3 x[4], const double t[4]) {
  double c[4], norm2 = 0.0;
  for (int i = 0; i < 4; ++i) {
    double prod = 1.0;
    for (int k = 0; k < 4; ++k) {
      if (k != i) prod *= t[i] - t[k];
    }
    if (prod == 0.0 || !std::isfinite(prod)) return std::nullopt;
    c[i] = 1.0 / prod;
    norm2 += c[i] * c[i];
  }
  Vec3 sum = Vec3::Zero();
  for (int i = 0; i < 4; ++i) sum += c[i] * x[i];
  return Vec3(sum.cwiseAbs() / std::sqrt(norm2));
}

Eigen::Vector2d calmRoughness(const std::vector<Vec3>& track, const std::vector<double>& stamps) {
  constexpr double kQuartileOfHalfNormal = 0.3186;
  const std::vector<Vec3> d = thirdDifferences(track, stamps);
  std::vector<double> h, v;
  for (const Vec3& x : d) {
    if (!x.allFinite()) continue;
    h.push_back(x.x()), h.push_back(x.y()), v.push_back(x.z());
  }
  const auto quartile = [](std::vector<double>& a) {
    if (a.empty()) return std::numeric_limits<double>::quiet_NaN();
    const auto k = static_cast<std::ptrdiff_t>(a.size() / 4);
    std::nth_element(a.begin(), a.begin() + k, a.end());
    return a[static_cast<std::size_t>(k)];
  };
  return Eigen::Vector2d(quartile(h), quartile(v)) / kQuartileOfHalfNormal;
}

Eigen::Vector2d roughness(const std::vector<Vec3>& track, const std::vector<double>& stamps) {
  const std::vector<Vec3> d = thirdDifferences(track, stamps);
  return spread(d, 0, d.size());
}

std::vector<Vec3> slamJitter(const std::vector<Vec3>& fixes, const std::vector<Vec3>& slam,
                             const std::vector<double>& stamps, int window, double floor) {
  std::vector<Vec3> out(fixes.size(), Vec3::Zero());
  const std::size_t w = static_cast<std::size_t>(std::max(2, window));
  if (fixes.size() < w + 3) return out;
  std::vector<Vec3> residual(fixes.size());
  for (std::size_t j = 0; j < fixes.size(); ++j) residual[j] = fixes[j] - slam[j];
  const std::vector<Vec3> dg = thirdDifferences(fixes, stamps);
  const std::vector<Vec3> dr = thirdDifferences(residual, stamps);
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
