#include "flexcloud/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace flexcloud {

void ErrorAccumulator::add(double distance) {
  ++n_;
  sum_ += distance;
  sum_sq_ += distance * distance;
  max_ = std::max(max_, distance);
}

void ErrorAccumulator::merge(const ErrorAccumulator& other) {
  n_ += other.n_;
  sum_ += other.sum_;
  sum_sq_ += other.sum_sq_;
  max_ = std::max(max_, other.max_);
}

ErrorStats ErrorAccumulator::stats() const {
  ErrorStats s;
  s.count = n_;
  if (n_ == 0) return s;
  const double n = static_cast<double>(n_);
  s.mae = sum_ / n;
  s.rmse = std::sqrt(sum_sq_ / n);
  s.std = std::sqrt(std::max(0.0, sum_sq_ / n - s.mae * s.mae));
  s.max = max_;
  return s;
}

double robustSigma(const std::vector<double>& values, double start) {
  constexpr double kTrim = 4.0;
  // The median |z| of a standard normal cut at kTrim: P(|z| <= m) = P(|z| <= kTrim) / 2.
  const double half = 0.5 * std::erf(kTrim / std::sqrt(2.0));
  double lo = 0.0, hi = kTrim;
  for (int i = 0; i < 60; ++i) {
    const double m = 0.5 * (lo + hi);
    (std::erf(m / std::sqrt(2.0)) < half ? lo : hi) = m;
  }
  const double core = 0.5 * (lo + hi);
  if (values.size() < 5) return std::numeric_limits<double>::quiet_NaN();
  double sigma = start > 0.0 ? start : 1.0;
  for (int iter = 0; iter < 50; ++iter) {
    std::vector<double> kept;
    for (double v : values) {
      if (std::abs(v) <= kTrim * sigma) kept.push_back(std::abs(v));
    }
    if (kept.size() < 5) {
      sigma *= 2.0;  // nothing within reach yet
      continue;
    }
    const double next = std::max(median(std::move(kept)) / core, 1e-12);
    const bool settled = std::abs(next - sigma) < 1e-4 * sigma;
    sigma = next;
    if (settled) break;
  }
  return sigma;
}

double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

ErrorStats errorStats(const std::vector<double>& distances) {
  ErrorAccumulator acc;
  for (double d : distances) acc.add(d);
  return acc.stats();
}

}  // namespace flexcloud
