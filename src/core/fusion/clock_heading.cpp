// The clock offset in the heading profiles, and the two profiles' offsets together
// (clock_offset.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "flexcloud/fusion/clock_offset.h"
#include "flexcloud/metrics.h"

namespace flexcloud {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSample = 0.1;          // s between the samples compared
constexpr double kBaseline = 1.0;        // s either side of a sample its course is taken over
constexpr double kRateStep = 0.1;        // s either side the SLAM's turn rate is taken over
constexpr double kMinSpeed = 3.0;        // m/s: a slower course is the GNSS's noise
constexpr double kMinTurn = 0.02;        // rad/s: a straighter sample shows no offset
constexpr std::size_t kTrendHalf = 100;  // samples either side of the heading trend (10 s)
constexpr std::size_t kMinSamples = 20;
// Rounds until the offset moves by less than kSettled: the trend (a moving median) takes in
// part of what the offset lacks where the road turns often, so each round makes up only a
// share of it.
constexpr int kRounds = 15;
constexpr double kSettled = 1e-4;
constexpr double kTukey = 4.685;
constexpr double kObservable = 0.1;   // s, the largest 1-sigma an offset is reported observable
constexpr std::size_t kChunks = 4;    // stretches whose offsets must agree
constexpr double kMaxInterval = 0.5;  // s, the fixes' median interval the course needs

/// Positions by stamp, linear between them.
struct Path {
  std::vector<double> t;
  std::vector<Eigen::Vector3d> p;
  bool at(double s, Eigen::Vector3d& out) const {
    const auto it = std::lower_bound(t.begin(), t.end(), s);
    if (it == t.begin() || it == t.end()) return false;
    const auto b = static_cast<std::size_t>(it - t.begin());
    const double span = t[b] - t[b - 1];
    if (!(span > 0.0) || span > 2.0 * kBaseline) return false;
    out = p[b - 1] + (s - t[b - 1]) / span * (p[b] - p[b - 1]);
    return true;
  }
  /// The horizontal course (rad) and speed (m/s) over s +- h; false where not available.
  bool course(double s, double h, double& heading, double& speed) const {
    Eigen::Vector3d a, b;
    if (!at(s - h, a) || !at(s + h, b)) return false;
    const Eigen::Vector2d d = (b - a).head<2>();
    heading = std::atan2(d.y(), d.x());
    speed = d.norm() / (2.0 * h);
    return true;
  }
};

double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

/// The median of v over [k - half, k + half] for every k, skipping NaN (NaN where none).
std::vector<double> movingMedian(const std::vector<double>& v, std::size_t half) {
  // Taken every `stride` samples and held between: the trend changes over tens of seconds.
  constexpr std::size_t stride = 10;
  std::vector<double> out(v.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < v.size(); k += stride) {
    std::vector<double> w;
    const std::size_t lo = k > half ? k - half : 0, hi = std::min(v.size(), k + half + 1);
    for (std::size_t m = lo; m < hi; ++m) {
      if (std::isfinite(v[m])) w.push_back(v[m]);
    }
    const double mid = w.empty() ? std::numeric_limits<double>::quiet_NaN() : median(w);
    for (std::size_t m = k; m < std::min(v.size(), k + stride); ++m) out[m] = mid;
  }
  return out;
}

/// y = x e, Tukey's biweight from least squares: e and its 1-sigma, the samples that share
/// a baseline counted once.
bool robustSlope(const std::vector<double>& x, const std::vector<double>& y, double& e,
                 double& sigma) {
  std::vector<double> w(x.size(), 1.0), r(x.size());
  double s = 0.0;
  for (int it = 0; it < 30; ++it) {
    double xy = 0.0, xx = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k) xy += w[k] * x[k] * y[k], xx += w[k] * x[k] * x[k];
    if (!(xx > 0.0)) return false;
    e = xy / xx;
    for (std::size_t k = 0; k < x.size(); ++k) r[k] = std::abs(y[k] - x[k] * e);
    s = 1.4826 * median(r) + 1e-12;
    for (std::size_t k = 0; k < x.size(); ++k) {
      const double u = r[k] / (kTukey * s);
      w[k] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
    }
  }
  double xx = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) xx += w[k] * x[k] * x[k];
  const double shared = 2.0 * kBaseline / kSample;
  sigma = xx > 0.0 ? s * std::sqrt(shared / xx) : kInf;
  return true;
}

/// One round at `offset` over the samples [lo, hi): the heading of the GNSS less the SLAM's at
/// the offset (the SLAM's frame and its drift, the trend, plus the turn rate times what the
/// offset lacks), detrended and regressed on the SLAM's turn rate. e is what the offset lacks;
/// returns the samples used (0 where the regression fails).
std::size_t slopeAt(const std::vector<double>& times, const std::vector<double>& heading,
                    const Path& slam, double offset, std::size_t lo, std::size_t hi, double& e,
                    double& sigma) {
  std::vector<double> diff(hi - lo, std::numeric_limits<double>::quiet_NaN());
  std::vector<double> rate(hi - lo, 0.0);
  for (std::size_t k = lo; k < hi; ++k) {
    double hs = 0.0, vs = 0.0, h0 = 0.0, h1 = 0.0, unused = 0.0;
    const double s = times[k] + offset;
    if (!slam.course(s, kBaseline, hs, vs) || vs < kMinSpeed) continue;
    if (!slam.course(s - kRateStep, kBaseline, h0, unused) ||
        !slam.course(s + kRateStep, kBaseline, h1, unused)) {
      continue;
    }
    diff[k - lo] = wrap(heading[k] - hs);
    rate[k - lo] = wrap(h1 - h0) / (2.0 * kRateStep);
  }
  const std::vector<double> trend = movingMedian(diff, kTrendHalf);
  std::vector<double> x, y;
  for (std::size_t k = 0; k < diff.size(); ++k) {
    if (!std::isfinite(diff[k]) || !std::isfinite(trend[k]) || std::abs(rate[k]) < kMinTurn) {
      continue;
    }
    x.push_back(rate[k]);
    y.push_back(wrap(diff[k] - trend[k]));
  }
  if (x.size() < kMinSamples || !robustSlope(x, y, e, sigma)) return 0;
  return x.size();
}

/// The offset's spread between kChunks stretches of the drive, each regressed on its own at the
/// drive's offset: the standard error of their mean. A SLAM whose heading wanders faster than
/// the trend follows it correlates with the turns by chance, stretch by stretch differently
/// (open_rtk_drifting: 40 ms from the whole drive, where there is none); the regression's own
/// sigma does not show that, their spread does.
double chunkSpread(const std::vector<double>& times, const std::vector<double>& heading,
                   const Path& slam, double offset) {
  std::vector<double> e;
  for (std::size_t c = 0; c < kChunks; ++c) {
    const std::size_t lo = c * times.size() / kChunks, hi = (c + 1) * times.size() / kChunks;
    double ec = 0.0, sc = 0.0;
    if (slopeAt(times, heading, slam, offset, lo, hi, ec, sc) > 0) e.push_back(ec);
  }
  if (e.size() < 2) return kInf;
  double mean = 0.0, var = 0.0;
  for (double x : e) mean += x / static_cast<double>(e.size());
  for (double x : e) var += (x - mean) * (x - mean) / static_cast<double>(e.size() - 1);
  return std::sqrt(var / static_cast<double>(e.size()));
}

}  // namespace

ClockOffsetEstimate estimateHeadingOffset(const Trajectory& poses, const Eigen::Vector3d& lever_arm,
                                          const std::vector<GnssPoint>& gnss, double start) {
  ClockOffsetEstimate out;
  out.sigma = kInf;
  Path slam, fixes;
  for (const auto& p : poses) {
    if (!slam.t.empty() && !(p.stamp > slam.t.back())) continue;
    slam.t.push_back(p.stamp);
    slam.p.push_back(p.position + p.orientation * lever_arm);
  }
  for (const auto& g : gnss) {
    if (!fixes.t.empty() && !(g.stamp > fixes.t.back())) continue;
    fixes.t.push_back(g.stamp);
    fixes.p.push_back(g.position);
  }
  if (slam.t.size() < 2 || fixes.t.size() < 2) return out;
  // A course between fixes further apart than the baseline is their chord, no heading of the
  // car: at 1 Hz it put urban_keyframes_1hz seed 2's offset 28 ms off at a sigma of 8 ms.
  std::vector<double> gaps;
  for (std::size_t k = 1; k < fixes.t.size(); ++k) gaps.push_back(fixes.t[k] - fixes.t[k - 1]);
  if (median(gaps) > kMaxInterval) return out;
  const double margin = std::abs(start) + kBaseline + kRateStep + 1.0;
  const double first = std::max(fixes.t.front(), slam.t.front() + margin) + kBaseline;
  const double last = std::min(fixes.t.back(), slam.t.back() - margin) - kBaseline;
  if (!(last > first)) return out;
  std::vector<double> heading, times;
  for (double s = first; s <= last; s += kSample) {
    double h = 0.0, v = 0.0;
    if (!fixes.course(s, kBaseline, h, v) || v < kMinSpeed) continue;
    times.push_back(s), heading.push_back(h);
  }
  double offset = start, sigma = kInf;
  std::size_t used = 0;
  for (int round = 0; round < kRounds; ++round) {
    double e = 0.0;
    used = slopeAt(times, heading, slam, offset, 0, times.size(), e, sigma);
    if (used < kMinSamples) return out;
    offset += e;
    if (std::abs(e) < kSettled) break;
  }
  out.offset = offset;
  out.sigma = std::max(sigma, chunkSpread(times, heading, slam, offset));
  out.samples = used;
  out.observable = out.sigma < kObservable;
  return out;
}

bool beyondSlamLag(double offset, double sigma, double k) {
  return std::abs(offset) > k * std::hypot(sigma, kSlamLag);
}

ClockEstimate combineClock(const ClockOffsetEstimate& speed, const ClockOffsetEstimate& heading) {
  ClockEstimate out;
  out.speed = speed;
  out.heading = heading;
  // The heading alone is not enough: a SLAM whose heading wanders can pass for an offset in
  // it (open_rtk_drifting, even speed: 49 ms where there is none), in the speed never.
  if (!speed.observable) {
    out.reason = heading.observable
                     ? "the speed varies too little to show it (the heading alone could take a "
                       "wandering SLAM heading for one)"
                     : "neither the speed nor the heading varies enough to show it";
    return out;
  }
  // The speed profile bounds the offset; the heading refines it where the speed knows it
  // tightly and the heading lies within that bound (its sigma and a SLAM's own lag, as
  // heldClockOffset's). Else it takes no part: a SLAM's heading that lags its path in turns (a
  // sensor ahead of the rear axle) passes for an offset in it, 150-290 ms on every MulRan drive,
  // and with a loose speed profile it took the clock 46 ms off where there was none.
  double offset = speed.offset, sigma = speed.sigma;
  out.disagree = heading.observable && std::abs(heading.offset - speed.offset) >
                                           kClockSignificant * std::hypot(speed.sigma, kSlamLag);
  if (heading.observable && !out.disagree && speed.sigma <= kLooseClock) {
    const double ws = 1.0 / (speed.sigma * speed.sigma);
    const double wh = 1.0 / (heading.sigma * heading.sigma);
    offset = (ws * speed.offset + wh * heading.offset) / (ws + wh);
    sigma = 1.0 / std::sqrt(ws + wh);
  }
  out.offset = offset;
  out.sigma = std::hypot(sigma, kClockSystematic);
  out.observable = beyondSlamLag(offset, out.sigma, kClockSignificant);
  out.loose = !out.observable && out.sigma > kLooseClock;
  if (!(std::abs(offset) > kClockSignificant * out.sigma)) {
    out.reason = "within its noise of 0";
  } else if (!out.observable) {
    out.within_lag = true;
    char bound[32];
    std::snprintf(bound, sizeof(bound), "%.0f",
                  1e3 * kClockSignificant * std::hypot(out.sigma, kSlamLag));
    out.reason = std::string("no more than a SLAM's own lag can show in its speed and heading (") +
                 bound + " ms at this sigma)";
  }
  return out;
}

}  // namespace flexcloud
