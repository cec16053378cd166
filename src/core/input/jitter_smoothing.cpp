#include "flexcloud/input/jitter_smoothing.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "flexcloud/fusion/slam_jitter.h"
#include "flexcloud/metrics.h"

namespace flexcloud {
namespace {

constexpr double kJitterShare = 0.75;  // of the third differences' variance, to be smoothed
// Of the jitter, the poses' own, to be smoothed: KITTI's LiDAR odometry 1.05-1.18 (its GNSS
// simulated apart from it); monza 0.27-0.33, its stamps made up at 10 Hz for poses and fixes
// alike.
constexpr double kOwnShare = 0.75;
// m: less is below what a fix or a map resolves, not worth the risk of taking a vehicle's own
// motion for it (a2rl: 6.9 mm, 0.82-1.05 of it its own as fixes are held out).
constexpr double kLeastJitter = 0.01;
constexpr int kLeastHalfWidth = 2;  // five poses: a cubic with one to spare
constexpr int kMostHalfWidth = 8;
constexpr double kStampSlack = 1e-6;  // s: stamps at 10 Hz written in decimals

/// Horizontal white-noise 1-sigma of every `step`-th pose from `first` on (roughness()).
double roughnessOf(const Trajectory& poses, std::size_t first, std::size_t step) {
  std::vector<Eigen::Vector3d> x;
  std::vector<double> t;
  for (std::size_t i = first; i < poses.size(); i += step) {
    x.push_back(poses[i].position);
    t.push_back(poses[i].stamp);
  }
  return roughness(x, t).x();
}

/// Poses [begin, end) a window may span.
struct Run {
  std::size_t begin = 0, end = 0;
};

/// The first pose of the window of 2k + 1 around pose i within `run`: shifted to stay within
/// it, k narrowed until the window spans at most kMostSpan; none below kLeastHalfWidth.
std::optional<std::size_t> windowStart(const Trajectory& t, const Run& run, std::size_t i, int& k) {
  for (; k >= kLeastHalfWidth; --k) {
    const auto n = static_cast<std::size_t>(2 * k + 1);
    if (run.end - run.begin < n) continue;
    const std::size_t lo = std::min(std::max(i, run.begin + k) - k, run.end - n);
    if (t[lo + n - 1].stamp - t[lo].stamp <= kMostSpan + kStampSlack) return lo;
  }
  return std::nullopt;
}

/// A window's weights, on the stack: at most 2 kMostHalfWidth + 1 poses.
using Weights = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 2 * kMostHalfWidth + 1, 1>;

/// The weights of poses [lo, lo + n) (0 for `skip`) in their least-squares cubic in time at
/// stamp `at`; n at most 2 kMostHalfWidth + 1.
Weights cubicWeights(const Trajectory& t, std::size_t lo, std::size_t n, std::size_t skip,
                     double at) {
  using Rows = Eigen::Matrix<double, Eigen::Dynamic, 4, 0, 2 * kMostHalfWidth + 1, 4>;
  Rows p = Rows::Zero(static_cast<Eigen::Index>(n), 4);
  for (std::size_t j = lo; j < lo + n; ++j) {
    if (j == skip) continue;
    const double u = (t[j].stamp - at) / kMostSpan;  // well conditioned: |u| <= 1
    p.row(static_cast<Eigen::Index>(j - lo)) << 1.0, u, u * u, u * u * u;
  }
  const Eigen::Matrix4d a = p.transpose() * p;
  return p * a.ldlt().solve(Eigen::Vector4d::UnitX());
}

/// The cubic's value at `at` (cubicWeights).
Eigen::Vector3d cubicAt(const Trajectory& t, std::size_t lo, std::size_t n, std::size_t skip,
                        double at) {
  const Weights w = cubicWeights(t, lo, n, skip, at);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t j = lo; j < lo + n; ++j)
    sum += w(static_cast<Eigen::Index>(j - lo)) * t[j].position;
  return sum;
}

/// The half-width of least leave-one-out error: each pose against the cubic through its
/// neighbours but itself, over the poses every candidate's window centres on.
int crossValidatedHalfWidth(const Trajectory& t, int most) {
  const auto m = static_cast<std::size_t>(most);
  double best = std::numeric_limits<double>::infinity();
  int chosen = 0;
  for (int k = kLeastHalfWidth; k <= most; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    double sum = 0.0;
    std::size_t n = 0;
    for (std::size_t i = m; i + m < t.size(); ++i) {
      if (t[i + m].stamp - t[i - m].stamp > kMostSpan + kStampSlack) continue;
      const double e =
          (t[i].position - cubicAt(t, i - kk, 2 * kk + 1, i, t[i].stamp)).squaredNorm();
      if (!std::isfinite(e)) continue;
      sum += e;
      ++n;
    }
    if (n > 0 && sum / static_cast<double>(n) < best)
      best = sum / static_cast<double>(n), chosen = k;
  }
  return chosen;
}

/// Runs of poses between those to keep.
std::vector<Run> runsBetween(std::size_t size, const std::vector<bool>& keep) {
  std::vector<Run> runs;
  Run r;
  for (std::size_t i = 0; i <= size; ++i) {
    if (i < size && !(i < keep.size() && keep[i])) continue;
    r.end = i;
    if (r.end > r.begin) runs.push_back(r);
    r.begin = i + 1;
  }
  return runs;
}

}  // namespace

double ownJitterShare(const Trajectory& aligned, const std::vector<GnssPoint>& fixes,
                      double white) {
  constexpr std::size_t kLeastWindows = 8;
  constexpr double kSameInstant = 1e-3;   // s
  constexpr double kRoughestFixes = 3.0;  // times the jitter
  // The fix stamped as each pose is, if any.
  std::vector<const GnssPoint*> at(aligned.size(), nullptr);
  for (const GnssPoint& f : fixes) {
    const auto it = std::lower_bound(aligned.begin(), aligned.end(), f.stamp - kSameInstant,
                                     [](const Pose& p, double t) { return p.stamp < t; });
    if (it != aligned.end() && it->stamp <= f.stamp + kSameInstant) at[it - aligned.begin()] = &f;
  }
  // Roughness over the poses with one (the motion, in both, cancels in the share): of the
  // poses, the fixes and the residuals, horizontal.
  std::vector<Eigen::Vector3d> poses, gnss, residual;
  std::vector<double> stamps;
  for (std::size_t i = 0; i < at.size(); ++i) {
    if (at[i] == nullptr) continue;
    poses.push_back(aligned[i].position);
    gnss.push_back(at[i]->position);
    residual.push_back(gnss.back() - poses.back());
    stamps.push_back(aligned[i].stamp);
  }
  if (poses.size() < kLeastWindows + 3 || !(white > 0.0)) return 1.0;
  const double p = roughness(poses, stamps).x(), g = roughness(gnss, stamps).x(),
               r = roughness(residual, stamps).x();
  if (!std::isfinite(p) || !std::isfinite(g) || !std::isfinite(r)) return 1.0;
  if (g > kRoughestFixes * white) return 1.0;
  return std::clamp((r * r + p * p - g * g) / (2.0 * white * white), 0.0, 1.0);
}

JitterSmoothing measureJitter(const Trajectory& poses, const std::vector<GnssPoint>& fixes) {
  JitterSmoothing s;
  if (poses.size() < 2 * kLeastHalfWidth + 5) return s;
  const double r1 = roughnessOf(poses, 0, 1);
  const double r2 = std::hypot(roughnessOf(poses, 0, 2), roughnessOf(poses, 1, 2)) / std::sqrt(2.0);
  if (!std::isfinite(r1) || !std::isfinite(r2)) return s;
  s.white = std::sqrt(std::max(0.0, (64.0 * r1 * r1 - r2 * r2) / 63.0));
  s.motion = std::sqrt(std::max(0.0, (r2 * r2 - r1 * r1) / 63.0));
  s.seen = s.white >= kLeastJitter && s.white * s.white >= kJitterShare * r1 * r1;
  if (!s.seen) return s;
  s.own_share = fixes.empty() ? 1.0 : ownJitterShare(poses, fixes, s.white);
  s.seen = s.own_share >= kOwnShare;
  if (!s.seen) return s;
  std::vector<double> steps;
  for (std::size_t i = 1; i < poses.size(); ++i)
    steps.push_back(poses[i].stamp - poses[i - 1].stamp);
  const double step = median(std::move(steps));
  const int most = std::min(kMostHalfWidth,
                            static_cast<int>(std::floor((kMostSpan + kStampSlack) / (2.0 * step))));
  if (most >= kLeastHalfWidth) s.half_width = crossValidatedHalfWidth(poses, most);
  return s;
}

std::vector<double> smoothJitter(Trajectory& t, int half_width, const std::vector<bool>& keep) {
  std::vector<double> left(t.size(), 1.0);
  if (half_width < kLeastHalfWidth) return left;
  half_width = std::min(half_width, kMostHalfWidth);
  const Trajectory given = t;
  // A pose without a finite position stays as it is and no window spans it.
  std::vector<bool> kept(t.size(), false);
  for (std::size_t i = 0; i < t.size(); ++i) {
    kept[i] = (i < keep.size() && keep[i]) || !t[i].position.allFinite();
  }
  for (const Run& run : runsBetween(t.size(), kept)) {
    for (std::size_t i = run.begin; i < run.end; ++i) {
      int k = half_width;
      const std::optional<std::size_t> lo = windowStart(given, run, i, k);
      if (!lo) continue;
      const auto n = static_cast<std::size_t>(2 * k + 1);
      const Weights w = cubicWeights(given, *lo, n, given.size(), given[i].stamp);
      t[i].position.setZero();
      for (std::size_t j = 0; j < n; ++j) {
        t[i].position += w(static_cast<Eigen::Index>(j)) * given[*lo + j].position;
      }
      left[i] = w.norm();
    }
  }
  return left;
}

}  // namespace flexcloud
