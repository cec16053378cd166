#include "uncertainty/random_walk.h"

#include <cmath>
#include <cstddef>

namespace flexcloud {
namespace walk {
namespace {

constexpr double kPrior = 1e4;  // m^2: the first observation alone sets the level

double step(const Series& s, std::size_t j) { return j == 0 ? 0.0 : s.along[j] - s.along[j - 1]; }

}  // namespace

double logLikelihood(const Series& s, double q) {
  double mean = 0.0, var = kPrior, ll = 0.0;
  for (std::size_t j = 0; j < s.value.size(); ++j) {
    var += q * step(s, j);
    const double innovation_var = var + s.var[j];
    const double innovation = s.value[j] - mean;
    if (j > 0) {
      ll -=
          0.5 * (innovation * innovation / innovation_var + std::log(2.0 * M_PI * innovation_var));
    }
    const double gain = var / innovation_var;
    mean += gain * innovation;
    var *= 1.0 - gain;
  }
  return ll;
}

std::vector<double> smoothedVariance(const Series& s, double q) {
  const std::size_t n = s.var.size();
  if (n == 0) return {};
  std::vector<double> predicted(n), filtered(n);
  double var = kPrior;
  for (std::size_t j = 0; j < n; ++j) {
    var += q * step(s, j);
    predicted[j] = var;
    var *= s.var[j] / (var + s.var[j]);
    filtered[j] = var;
  }
  std::vector<double> smoothed = filtered;
  for (std::size_t j = n - 1; j-- > 0;) {
    const double c = filtered[j] / predicted[j + 1];
    smoothed[j] = filtered[j] + c * c * (smoothed[j + 1] - predicted[j + 1]);
  }
  return smoothed;
}

double learnIntensity(const std::vector<Series>& axes) {
  const auto total = [&](double log_q) {
    double ll = 0.0;
    for (const Series& s : axes) ll += logLikelihood(s, std::pow(10.0, log_q));
    return ll;
  };
  // Golden-section search for the maximum on log10 q.
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = -9.0, b = 1.0;
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = total(c), fd = total(d);
  for (int i = 0; i < 40; ++i) {
    if (fc > fd) {
      b = d, d = c, fd = fc;
      c = b - g * (b - a), fc = total(c);
    } else {
      a = c, c = d, fc = fd;
      d = a + g * (b - a), fd = total(d);
    }
  }
  return std::pow(10.0, 0.5 * (a + b));
}

}  // namespace walk
}  // namespace flexcloud
