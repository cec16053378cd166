#include "follow_series.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "flexcloud/fusion/slam_jitter.h"
#include "flexcloud/metrics.h"

namespace flexcloud {
namespace follow {
namespace {

constexpr double kRoughClaims = 2.0;
constexpr std::size_t kJumpWindow = 5;
constexpr double kJumpSpread = 3.0, kJumpSigmas = 8.0;

/// Path length of the fused trajectory from its first pose to each pose.
std::vector<double> pathOf(const Trajectory& poses) {
  std::vector<double> s(poses.size(), 0.0);
  for (std::size_t i = 1; i < poses.size(); ++i) {
    s[i] = s[i - 1] + (poses[i].position - poses[i - 1].position).norm();
  }
  return s;
}

double pathAt(const Trajectory& poses, const std::vector<double>& s, double t, std::size_t& k) {
  while (k + 2 < poses.size() && poses[k + 1].stamp <= t) ++k;
  const double span = poses[k + 1].stamp - poses[k].stamp;
  const double u = span > 0.0 ? std::clamp((t - poses[k].stamp) / span, 0.0, 1.0) : 0.0;
  return (1.0 - u) * s[k] + u * s[k + 1];
}

/// Normalised |third divided differences| of a series (white noise of 1-sigma s gives s);
/// NaN where four stamps do not increase.
std::vector<Vec3> thirdDifferences(const std::vector<Vec3>& x, const std::vector<double>& t) {
  std::vector<Vec3> d(x.size() > 3 ? x.size() - 3 : 0);
  for (std::size_t j = 0; j < d.size(); ++j) {
    const std::optional<Vec3> v = thirdDividedDifference(&x[j], &t[j]);
    d[j] = v ? *v : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return d;
}

/// The horizontal white-noise 1-sigma of d[lo, hi) (median |difference| / 0.6745).
double roughAround(const std::vector<Vec3>& d, std::size_t lo, std::size_t hi) {
  std::vector<double> h;
  for (std::size_t k = lo; k < hi; ++k) {
    if (d[k].allFinite()) h.push_back(d[k].x()), h.push_back(d[k].y());
  }
  return h.empty() ? 0.0 : median(std::move(h)) / 0.6745;
}

}  // namespace

Vec3 ownStd(const FusionResult& f, const FixOutcome& x) {
  if (x.std_given || !f.unknown_white.allFinite()) return x.std_dev;
  return Vec3(f.unknown_white.x(), f.unknown_white.x(), f.unknown_white.y());
}

void Series::add(const Series& from, std::size_t j) {
  r.push_back(from.r[j]);
  var.push_back(from.var[j]);
  t.push_back(from.t[j]);
  along.push_back(from.along[j]);
  claim.push_back(from.claim[j]);
  doubt.push_back(from.doubt[j]);
  noise.push_back(from.noise[j]);
  fix.push_back(from.fix[j]);
}

Pose poseAt(const Trajectory& poses, double t, std::size_t& k) {
  while (k + 2 < poses.size() && poses[k + 1].stamp <= t) ++k;
  const Pose& a = poses[k];
  const Pose& b = poses[std::min(k + 1, poses.size() - 1)];
  const double span = b.stamp - a.stamp;
  const double u = span > 0.0 ? std::clamp((t - a.stamp) / span, 0.0, 1.0) : 0.0;
  Pose p;
  p.stamp = t;
  p.position = (1.0 - u) * a.position + u * b.position;
  p.orientation = a.orientation.slerp(u, b.orientation);
  return p;
}

Series gather(const FusionResult& f, const FollowOptions& o) {
  std::vector<std::size_t> order;
  const double first = f.poses.front().stamp, last = f.poses.back().stamp;
  for (std::size_t j : judgedByStamp(f)) {
    const FixOutcome& x = f.fixes[j];
    if (!(ownStd(f, x).x() <= o.max_std)) continue;
    const double t = x.stamp + f.time_offset;
    if (t >= first && t <= last) order.push_back(j);
  }
  // The stamps of the fixes that claimed less than max_std (a float solution, a receiver that
  // knows it is off): where one lies between two fixes of the series, its status changed.
  std::vector<double> worse;
  for (const FixOutcome& x : f.fixes) {
    if (x.std_given && x.std_dev.allFinite() && x.std_dev.x() > o.max_std) worse.push_back(x.stamp);
  }
  std::sort(worse.begin(), worse.end());
  Series s;
  const std::vector<double> path = pathOf(f.poses);
  std::size_t k = 0, kp = 0;
  double before = -std::numeric_limits<double>::infinity();
  for (std::size_t j : order) {
    const FixOutcome& x = f.fixes[j];
    const double t = x.stamp + f.time_offset;
    const Pose p = poseAt(f.poses, t, k);
    const Vec3 sd = ownStd(f, x);
    s.r.push_back(x.position - (p.position + p.orientation * f.lever_arm));
    s.var.push_back(sd.cwiseProduct(sd) + Vec3::Constant(x.slam_gap * x.slam_gap));
    s.along.push_back(pathAt(f.poses, path, t, kp) + o.time_metres * (t - f.poses.front().stamp));
    s.t.push_back(t);
    s.claim.push_back(x.std_given ? x.std_dev.x() : std::numeric_limits<double>::quiet_NaN());
    const auto w = std::upper_bound(worse.begin(), worse.end(), before);
    s.doubt.push_back(w != worse.end() && *w < x.stamp);
    s.noise.push_back(std::numeric_limits<double>::quiet_NaN());
    before = x.stamp;
    s.fix.push_back(j);
  }
  return s;
}

Series keepTheSmooth(const Series& s, const std::vector<Vec3>& positions) {
  if (s.size() < 2 * kNoiseReach + 4) return s;
  const std::vector<Vec3> dr = thirdDifferences(s.r, s.t);
  const std::vector<Vec3> dp = thirdDifferences(positions, s.t);
  Series measured = s;
  Series out;
  for (std::size_t j = 0; j < s.size(); ++j) {
    const std::size_t lo = j > kNoiseReach ? j - kNoiseReach : 0;
    const std::size_t hi = std::min(dr.size(), j + kNoiseReach);
    measured.noise[j] = roughAround(dp, lo, hi);
    const double rough = std::min(roughAround(dr, lo, hi), measured.noise[j]);
    if (rough <= kRoughClaims * std::sqrt(s.var[j].x())) out.add(measured, j);
  }
  return out;
}

double madSigma(std::vector<double> v) {
  const double middle = median(v);
  for (double& x : v) x = std::abs(x - middle);
  return 1.4826 * median(std::move(v));
}

std::vector<double> detectJumps(const Series& s) {
  std::vector<double> out(s.size(), 0.0);
  if (s.size() < 2 * kJumpWindow) return out;
  for (std::size_t j = kJumpWindow; j + kJumpWindow <= s.size(); ++j) {
    double chi2 = 0.0;
    bool agree = true;
    for (int a = 0; a < 3 && agree; ++a) {
      std::vector<double> before, after;
      double own = 0.0;
      for (std::size_t k = 0; k < kJumpWindow; ++k) {
        before.push_back(s.r[j - kJumpWindow + k](a));
        after.push_back(s.r[j + k](a));
        own = std::max({own, s.var[j - kJumpWindow + k](a), s.var[j + k](a)});
      }
      const double sb = madSigma(before), sa = madSigma(after), sd = std::sqrt(own);
      agree = sb <= kJumpSpread * sd && sa <= kJumpSpread * sd;
      const double d = (median(after) - median(before)) / std::max({sd, sb, sa});
      chi2 += d * d;
    }
    if (agree && chi2 > kJumpSigmas * kJumpSigmas) out[j] = 1.0;
  }
  return out;
}

}  // namespace follow
}  // namespace flexcloud
