#pragma once
// Deviation statistics.

#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

/// MAE, STD, MAX and RMSE of a set of distances (m); all zero for an empty set.
ErrorStats errorStats(const std::vector<double>& distances);

/// The median of the values (the upper middle one of an even count); NaN when there are none.
double median(std::vector<double> values);

/// The 1-sigma of the Gaussian core of zero-mean values that carry outliers and biased
/// stretches beyond it: the median of the |values| within 4 sigma, over the median |z| of a
/// standard normal within 4, iterated from `start` to its fixed point. Every value takes part;
/// only those far beyond the core are left out, whatever sigma it starts from (one that starts
/// too small grows: the values between it and 4 of it raise the median). NaN for fewer than 5
/// values.
double robustSigma(const std::vector<double>& values, double start);

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
