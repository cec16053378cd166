#include "flexcloud/fusion/clock_offset.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "flexcloud/metrics.h"

namespace flexcloud {
namespace {

constexpr double kStep = 0.02;            // s between the offsets compared
constexpr int kSampleSteps = 5;           // speed samples every kSampleSteps * kStep = 0.1 s
constexpr double kBaseline = 0.5;         // s either side of a sample its speed is taken over
constexpr double kMaxGap = 1.5;           // s, largest gap a speed is taken across, at least
constexpr double kGapIntervals = 2.5;     // the same in median intervals of the track
constexpr double kClip = 0.5;             // m/s, a speed residual beyond counts as this (outliers)
constexpr double kObservable = 0.15;      // s, largest 1-sigma an offset is reported observable
constexpr std::size_t kMinSamples = 20;   // changing samples (2 s of braking)
constexpr double kMinAcceleration = 0.3;  // m/s^2 of a changing sample: 10x the GNSS's noise
constexpr int kCurvatureSteps = 5;        // the cost's curvature is taken over +-0.1 s

/// Stamped positions.
struct Track {
  std::vector<double> t;
  std::vector<Eigen::Vector3d> p;
  double max_gap = kMaxGap;  ///< s, set by finish()

  /// Sizes the gap limit from the track's own rate: a receiver at 0.5 Hz has its fixes two
  /// seconds apart, and none of its speeds would pass a fixed limit of 1.5 s.
  void finish() {
    std::vector<double> d;
    for (std::size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
    max_gap = std::max(kMaxGap, kGapIntervals * (d.empty() ? 0.0 : median(d)));
  }

  /// Linear interpolation at s; false outside the track or across a gap beyond max_gap.
  bool at(double s, Eigen::Vector3d& out) const {
    const auto it = std::lower_bound(t.begin(), t.end(), s);
    if (it == t.begin() || it == t.end()) return false;
    const std::size_t b = static_cast<std::size_t>(it - t.begin());
    const double span = t[b] - t[b - 1];
    if (span > max_gap || span <= 0.0) return false;
    const double f = (s - t[b - 1]) / span;
    out = p[b - 1] + f * (p[b] - p[b - 1]);
    return true;
  }

  /// Speed at s over +-h; NaN where not available.
  double speed(double s, double h) const {
    Eigen::Vector3d a, b;
    if (!at(s - h, a) || !at(s + h, b)) return std::numeric_limits<double>::quiet_NaN();
    return (b - a).norm() / (2.0 * h);
  }
};

Track slamTrack(const Trajectory& poses) {
  Track out;
  for (const auto& p : poses) {
    out.t.push_back(p.stamp);
    out.p.push_back(p.position);
  }
  out.finish();
  return out;
}

Track gnssTrack(const std::vector<GnssPoint>& gnss) {
  Track out;
  for (const auto& g : gnss) {
    if (!out.t.empty() && g.stamp <= out.t.back()) continue;
    out.t.push_back(g.stamp);
    out.p.push_back(g.position);
  }
  out.finish();
  return out;
}

/// The speeds compared: the GNSS's at every sample, the SLAM's on the finer grid of offsets,
/// sample k at grid index k * kSampleSteps + shift for offset (shift - reach) * kStep.
struct Profiles {
  std::vector<double> gnss;    ///< per sample, NaN where not available
  std::vector<bool> changing;  ///< per sample: the GNSS's speed changes there (informative)
  std::vector<double> slam;    ///< per grid step
  /// Grid steps either side of zero: the largest offset and kCurvatureSteps more, so that an
  /// offset near the range's edge has the cost around it for its sigma, and one just beyond
  /// shows as beyond instead of as the edge.
  int reach = 0;
};

Profiles profiles(const Track& slam, const Track& gnss, double max_offset) {
  Profiles out;
  out.reach = static_cast<int>(std::ceil(max_offset / kStep)) + kCurvatureSteps;
  const double h = kBaseline;
  const double margin = out.reach * kStep + h;
  const double first = std::max(gnss.t.front(), slam.t.front() + margin);
  const double last = std::min(gnss.t.back(), slam.t.back() - margin);
  if (!(last > first)) return out;
  const auto samples = static_cast<std::size_t>((last - first) / (kSampleSteps * kStep)) + 1;
  const double grid0 = first - out.reach * kStep;
  const std::size_t grid = (samples - 1) * kSampleSteps + 2 * out.reach + 1;
  for (std::size_t j = 0; j < grid; ++j) out.slam.push_back(slam.speed(grid0 + j * kStep, h));
  for (std::size_t k = 0; k < samples; ++k) {
    out.gnss.push_back(gnss.speed(first + k * kSampleSteps * kStep, h));
  }
  // Only where the speed changes does an offset show; the even stretches would add nothing
  // but their noise, whose own correlation makes a flat cost look curved.
  const auto reach = static_cast<std::size_t>(std::lround(h / (kSampleSteps * kStep)));
  out.changing.assign(samples, false);
  for (std::size_t k = reach; k + reach < samples; ++k) {
    const double change = std::abs(out.gnss[k + reach] - out.gnss[k - reach]) / (2.0 * h);
    out.changing[k] = change > kMinAcceleration;  // false for NaN
  }
  return out;
}

/// Robust cost of offset index i (0 .. 2 reach): truncated squares of the speed residuals.
double cost(const Profiles& p, double scale, int i, std::size_t* used = nullptr) {
  double c = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < p.gnss.size(); ++k) {
    const double s = p.slam[k * kSampleSteps + static_cast<std::size_t>(i)];
    if (!p.changing[k] || !std::isfinite(p.gnss[k]) || !std::isfinite(s)) continue;
    const double r = p.gnss[k] - scale * s;
    c += std::min(r * r, kClip * kClip);
    ++n;
  }
  if (used) *used = n;
  return c;
}

/// The SLAM's speed scale against the GNSS's (its scale error), from the moving samples.
double speedScale(const Profiles& p) {
  std::vector<double> ratio;
  for (std::size_t k = 0; k < p.gnss.size(); ++k) {
    const double s = p.slam[k * kSampleSteps + static_cast<std::size_t>(p.reach)];
    if (std::isfinite(p.gnss[k]) && std::isfinite(s) && s > 1.0) ratio.push_back(p.gnss[k] / s);
  }
  return ratio.size() < kMinSamples ? 1.0 : median(ratio);
}

/// 1-sigma of the offset at index i from the cost's curvature over +-kCurvatureSteps (a speed
/// that varies too little leaves the cost flat: a large sigma) and the residuals' robust
/// spread, with the samples that share a baseline counted once.
double offsetSigma(const Profiles& p, double scale, const std::vector<double>& c, int i) {
  const int m = kCurvatureSteps;
  if (i - m < 0 || i + m >= static_cast<int>(c.size())) {
    return std::numeric_limits<double>::infinity();
  }
  const double h = m * kStep;
  const double curvature = (c[i - m] - 2.0 * c[i] + c[i + m]) / (h * h);
  std::vector<double> residual;
  for (std::size_t k = 0; k < p.gnss.size(); ++k) {
    const double s = p.slam[k * kSampleSteps + static_cast<std::size_t>(i)];
    if (p.changing[k] && std::isfinite(p.gnss[k]) && std::isfinite(s)) {
      residual.push_back(std::abs(p.gnss[k] - scale * s));
    }
  }
  if (residual.size() < kMinSamples || !(curvature > 0.0)) {
    return std::numeric_limits<double>::infinity();
  }
  const double spread = 1.4826 * median(residual);
  const double shared = 2.0 * kBaseline / (kSampleSteps * kStep);
  return std::sqrt(2.0 * spread * spread * shared / curvature);
}

}  // namespace

ClockOffsetEstimate estimateClockOffset(const Trajectory& poses, const std::vector<GnssPoint>& gnss,
                                        double max_offset) {
  ClockOffsetEstimate out;
  out.sigma = std::numeric_limits<double>::infinity();
  if (poses.size() < 2 || gnss.size() < 2 || !(max_offset > 0.0)) return out;
  const Profiles p = profiles(slamTrack(poses), gnssTrack(gnss), max_offset);
  if (p.gnss.empty()) return out;
  const double scale = speedScale(p);
  std::vector<double> c;
  for (int i = 0; i <= 2 * p.reach; ++i) c.push_back(cost(p, scale, i));
  const int best = static_cast<int>(std::min_element(c.begin(), c.end()) - c.begin());
  cost(p, scale, best, &out.samples);
  if (best == 0 || best == 2 * p.reach || out.samples < kMinSamples) return out;
  const double curvature = c[best - 1] - 2.0 * c[best] + c[best + 1];
  const double shift = curvature > 0.0 ? 0.5 * (c[best - 1] - c[best + 1]) / curvature : 0.0;
  const double offset = (best - p.reach + shift) * kStep;
  if (std::abs(offset) > max_offset) return out;  // beyond the range asked for
  out.offset = offset;
  out.sigma = offsetSigma(p, scale, c, best);
  // Within kObservable, whether the offset is told from 0 decides (combineClock). KITTI 03 with
  // 1 Hz urban GNSS, its stamps 0.3 s off, shows 0.25 +- 0.10 s: left out at 0.1 s, the 0.3 s
  // stayed, 2.6 m along the track.
  out.observable = out.sigma < kObservable;
  return out;
}

std::optional<double> heldClockOffset(double fitted, const ClockOffsetEstimate& speeds) {
  // The fit may move the offset as far from the speed profiles' as a SLAM's own lag moves
  // them (kSlamLag, with their sigma: KITTI 02 RTK, the speed profile 15 ms off the truth and
  // the fit within 5 ms of it), never further: MulRan's fit of positions lay 120-140 ms from
  // their offset (and from the truth) where the SLAM's heading lags its path in turns.
  if (!speeds.observable || !(std::abs(fitted - speeds.offset) >
                              kClockSignificant * std::hypot(speeds.sigma, kSlamLag))) {
    return std::nullopt;
  }
  // Held at theirs where they tell it from 0 by three of their sigmas, else at the stamps as
  // given: MulRan Riverside_02 with 1 Hz urban GNSS, 112 +- 38 ms where the truth is 48 ms, held
  // there 3.14 m RMSE against the truth, at 0 2.56 m.
  constexpr double kSignificant = 3.0;
  return std::abs(speeds.offset) > kSignificant * speeds.sigma ? speeds.offset : 0.0;
}

}  // namespace flexcloud
