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
