#pragma once
// A one-dimensional random walk along the path observed with white noise: the smoother's
// variance at each observation, and the walk's intensity by maximum likelihood. Private to the
// core (pose_sigma.cpp).

#include <vector>

namespace flexcloud {
namespace walk {

/// Observations in path order: value, its noise variance, its place on the path (m).
struct Series {
  std::vector<double> value, var, along;
};

/// The log-likelihood of the series under a walk of intensity q (m^2 per m) started from a
/// broad prior (the first observation sets its level).
double logLikelihood(const Series& s, double q);

/// The smoothed variance of the walk at each observation (forward filter, backward pass).
std::vector<double> smoothedVariance(const Series& s, double q);

/// The intensity maximising the summed likelihood of the series (each an axis of the same walk),
/// searched on a log scale between 1e-9 and 10 m^2 per m.
double learnIntensity(const std::vector<Series>& axes);

}  // namespace walk
}  // namespace flexcloud
