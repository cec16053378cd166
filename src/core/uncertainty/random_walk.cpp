#include "uncertainty/random_walk.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <utility>

namespace flexcloud {
namespace walk {
namespace {

using Mat2 = Eigen::Matrix2d;
using Vec2 = Eigen::Vector2d;

constexpr double kLevelPrior = 1e4;  // m^2: the first observation alone sets the level
constexpr double kRatePrior = 1.0;   // (m/m)^2: any slope of the correction

struct Filtered {
  std::vector<Mat2> predicted, filtered;
};

/// The state's covariance carried over d metres, with the noise it gathers.
void propagateCovariance(double d, const Intensity& q, Mat2& p) {
  Mat2 f;
  f << 1.0, d, 0.0, 1.0;
  Mat2 noise;
  noise << q.value * d + q.rate * d * d * d / 3.0, q.rate * d * d / 2.0, q.rate * d * d / 2.0,
      q.rate * d;
  p = f * p * f.transpose() + noise;
}

/// The forward filter's predicted and filtered covariances at every entry.
Filtered filter(const Series& s, const Intensity& q) {
  Filtered out;
  Mat2 p = Mat2::Zero();
  p(0, 0) = kLevelPrior;
  p(1, 1) = q.rate > 0.0 ? kRatePrior : 0.0;
  for (std::size_t j = 0; j < s.var.size(); ++j) {
    propagateCovariance(j == 0 ? 0.0 : s.along[j] - s.along[j - 1], q, p);
    out.predicted.push_back(p);
    if (std::isfinite(s.var[j])) {
      const Vec2 gain = p.col(0) / (p(0, 0) + s.var[j]);
      p -= gain * p.row(0);
    }
    out.filtered.push_back(p);
  }
  return out;
}

/// The summed log-likelihood of several value series observed at the same places with the same
/// variances as `s`: the covariance is the same for all of them and is carried once.
double jointLogLikelihood(const std::vector<const std::vector<double>*>& values, const Series& s,
                          const Intensity& q) {
  std::vector<Vec2> x(values.size(), Vec2::Zero());
  Mat2 p = Mat2::Zero();
  p(0, 0) = kLevelPrior;
  p(1, 1) = q.rate > 0.0 ? kRatePrior : 0.0;
  double ll = 0.0;
  // The sum of the innovation variances' logarithms as a product of their mantissas and a sum
  // of their exponents: one logarithm a series instead of one a fix and axis (the learning's
  // main cost), and no variance of any size overflows it.
  double variances = 1.0;
  long exponent = 0;
  std::size_t terms = 0;
  bool first = true;
  for (std::size_t j = 0; j < s.var.size(); ++j) {
    const double d = j == 0 ? 0.0 : s.along[j] - s.along[j - 1];
    for (Vec2& xa : x) xa(0) += d * xa(1);
    propagateCovariance(d, q, p);
    if (!std::isfinite(s.var[j])) continue;
    const double innovation_var = p(0, 0) + s.var[j];
    const Vec2 gain = p.col(0) / innovation_var;
    for (std::size_t a = 0; a < x.size(); ++a) {
      const double innovation = (*values[a])[j] - x[a](0);
      if (!first) ll -= 0.5 * innovation * innovation / innovation_var;
      x[a] += gain * innovation;
    }
    if (!first) {  // mantissas in [0.5, 1): 32 of them cannot leave the doubles' range
      int e = 0;
      variances *= std::frexp(innovation_var, &e);
      exponent += e;
      if (++terms % 32 == 0) {
        variances = std::frexp(variances, &e);
        exponent += e;
      }
    }
    first = false;
    p -= gain * p.row(0);
  }
  const double log_sum = std::log(variances) + static_cast<double>(exponent) * std::log(2.0);
  return ll - 0.5 * static_cast<double>(x.size()) *
                  (log_sum + static_cast<double>(terms) * std::log(2.0 * M_PI));
}

/// The maximum of f on [a, b] by golden section.
double goldenMax(const std::function<double(double)>& f, double a, double b, int steps) {
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = f(c), fd = f(d);
  for (int i = 0; i < steps; ++i) {
    if (fc > fd) {
      b = d, d = c, fd = fc;
      c = b - g * (b - a), fc = f(c);
    } else {
      a = c, c = d, fc = fd;
      d = a + g * (b - a), fd = f(d);
    }
  }
  return 0.5 * (a + b);
}

}  // namespace

double logLikelihood(const Series& s, const Intensity& q) {
  return jointLogLikelihood({&s.value}, s, q);
}

std::vector<double> smoothedVariance(const Series& s, const Intensity& q) {
  const std::size_t n = s.var.size();
  if (n == 0) return {};
  const Filtered f = filter(s, q);
  std::vector<Mat2> smoothed = f.filtered;
  for (std::size_t j = n - 1; j-- > 0;) {
    const double d = s.along[j + 1] - s.along[j];
    Mat2 transition;
    transition << 1.0, d, 0.0, 1.0;
    const Mat2& next = f.predicted[j + 1];
    // A rate left out (or pinned) leaves a singular prediction: its part of the gain is 0.
    Mat2 gain = Mat2::Zero();
    if (next(1, 1) > 0.0 && next.determinant() > 0.0) {
      gain = f.filtered[j] * transition.transpose() * next.inverse();
    } else if (next(0, 0) > 0.0) {
      gain.col(0) = (f.filtered[j] * transition.transpose()).col(0) / next(0, 0);
    }
    smoothed[j] = f.filtered[j] + gain * (smoothed[j + 1] - next) * gain.transpose();
  }
  std::vector<double> out(n);
  for (std::size_t j = 0; j < n; ++j) out[j] = smoothed[j](0, 0);
  return out;
}

Intensity learnIntensity(const std::vector<Series>& axes) {
  // Axes observed at the same places with the same variances share one covariance pass.
  std::vector<std::pair<const Series*, std::vector<const std::vector<double>*>>> groups;
  for (const Series& s : axes) {
    auto g = std::find_if(groups.begin(), groups.end(), [&](const auto& x) {
      return x.first->var == s.var && x.first->along == s.along;
    });
    if (g == groups.end()) {
      groups.push_back({&s, {}});
      g = groups.end() - 1;
    }
    g->second.push_back(&s.value);
  }
  const auto total = [&](const Intensity& t) {
    double ll = 0.0;
    for (const auto& [s, values] : groups) ll += jointLogLikelihood(values, *s, t);
    return ll;
  };
  Intensity q{1e-5, 1e-8};
  for (int round = 0; round < 2; ++round) {
    q.value = std::pow(10.0, goldenMax(
                                 [&](double e) {
                                   return total({std::pow(10.0, e), q.rate});
                                 },
                                 -10.0, 1.0, 18));
    q.rate = std::pow(10.0, goldenMax(
                                [&](double e) {
                                  return total({q.value, std::pow(10.0, e)});
                                },
                                -14.0, -2.0, 18));
  }
  return q;
}

}  // namespace walk
}  // namespace flexcloud
