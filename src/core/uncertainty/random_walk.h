#pragma once
// A correction that wanders along the path, observed with white noise: a random walk of its
// value plus an integrated random walk (a rate that itself wanders), the way a SLAM's drift
// both jitters and bends. The smoother's variance at every entry, and the two intensities by
// maximum likelihood. Private to the core (pose_sigma.cpp).

#include <vector>

namespace flexcloud {
namespace walk {

/// Entries in path order: value, its noise variance (infinite: no observation, only a place
/// where the variance is wanted), its place on the path (m).
struct Series {
  std::vector<double> value, var, along;
};

/// The walk's intensities: of the value (m^2 per m) and of its rate (m^2 per m^3). A rate
/// intensity of 0 leaves the rate out (a plain random walk).
struct Intensity {
  double value = 0.0;
  double rate = 0.0;
};

/// The log-likelihood of the series' observations under `q`, started from a broad prior (the
/// first observation sets the level).
double logLikelihood(const Series& s, const Intensity& q);

/// The smoothed variance of the value at every entry (forward filter, backward pass).
std::vector<double> smoothedVariance(const Series& s, const Intensity& q);

/// The intensities maximising the summed likelihood of the series (each an axis of the same
/// walk): golden sections on log scales, the value's and the rate's in turn.
Intensity learnIntensity(const std::vector<Series>& axes);

}  // namespace walk
}  // namespace flexcloud
