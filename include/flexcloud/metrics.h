#pragma once
// Deviation statistics.

#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

/// MAE, STD, MAX and RMSE of a set of distances (m); all zero for an empty set.
ErrorStats errorStats(const std::vector<double>& distances);

/// The median of the values (the upper middle one of an even count); NaN when there are none.
double median(std::vector<double> values);

/// Accumulates squared and absolute errors one at a time (for clouds too big to keep).
class ErrorAccumulator {
 public:
  void add(double distance);
  void merge(const ErrorAccumulator& other);
  ErrorStats stats() const;

 private:
  std::size_t n_ = 0;
  double sum_ = 0.0;
  double sum_sq_ = 0.0;
  double max_ = 0.0;
};

}  // namespace flexcloud
