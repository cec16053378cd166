#include "flexcloud/uncertainty/pose_sigma.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "uncertainty/random_walk.h"

namespace flexcloud {
namespace {

// Calibrated on the nine kitti_lo drives (RTK and urban GNSS) and the simulated drives against
// their truth (doc/ACCURACY.md): the weights of the walk's variance and of the local mean
// residual, horizontal and vertical.
constexpr double kWalkH = 1.25;
constexpr double kMeanResidualH = 0.95;
constexpr double kWalkV = 0.87;
constexpr double kScatterV = 0.66;
constexpr double kWindow = 10.0;       // m of path: the Gaussian window of the local residuals
constexpr double kTimeMetres = 0.1;    // m of path per second: a standstill still counts
constexpr double kStretchShare = 0.5;  // the worst stretch: poses at half its sigma or more

/// Horizontal path length at every pose.
std::vector<double> pathLength(const Trajectory& t) {
  std::vector<double> s(t.size(), 0.0);
  for (std::size_t i = 1; i < t.size(); ++i) {
    s[i] = s[i - 1] + (t[i].position - t[i - 1].position).head<2>().norm();
  }
  return s;
}

/// Linear interpolation of per-pose values at instant `t` (clamped to the span); k is the
/// search's start, kept between calls with rising t.
template <typename Value>
Value at(const Trajectory& poses, const std::vector<Value>& values, double t, std::size_t& k) {
  if (poses.size() == 1) return values[0];
  while (k + 2 < poses.size() && poses[k + 1].stamp <= t) ++k;
  const double span = poses[k + 1].stamp - poses[k].stamp;
  const double u = span > 0.0 ? std::clamp((t - poses[k].stamp) / span, 0.0, 1.0) : 0.0;
  return values[k] + u * (values[k + 1] - values[k]);
}

std::vector<Eigen::Vector3d> positions(const Trajectory& t) {
  std::vector<Eigen::Vector3d> p;
  p.reserve(t.size());
  for (const Pose& x : t) p.push_back(x.position);
  return p;
}

/// The walk's smoothed variance carried from the fixes (at path places `fix_along`) to the
/// poses (at `pose_along`): between two fixes their variances blended plus the walk's bridge,
/// beyond the first or last fix the walk's growth.
std::vector<double> toPoses(const std::vector<double>& fix_var,
                            const std::vector<double>& fix_along,
                            const std::vector<double>& pose_along, double q) {
  std::vector<double> out(pose_along.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < pose_along.size(); ++i) {
    const double s = pose_along[i];
    while (k < fix_along.size() && fix_along[k] < s) ++k;
    if (k == 0) {
      out[i] = fix_var.front() + q * (fix_along.front() - s);
    } else if (k == fix_along.size()) {
      out[i] = fix_var.back() + q * (s - fix_along.back());
    } else {
      const double a = s - fix_along[k - 1], b = fix_along[k] - s, l = a + b;
      out[i] = l > 0.0 ? (fix_var[k - 1] * b + fix_var[k] * a) / l + q * a * b / l : fix_var[k];
    }
  }
  return out;
}

/// Near each pose (a Gaussian window along the result's path): the squared mean of the fixes'
/// horizontal residuals from the result, per axis, and the vertical residuals' mean square
/// over the window's effective number of fixes.
struct LocalResiduals {
  std::vector<double> mean_h2, scatter_v2;
};

LocalResiduals localResiduals(const std::vector<double>& pose_s, const std::vector<double>& fix_s,
                              const std::vector<Eigen::Vector3d>& residual) {
  LocalResiduals out{std::vector<double>(pose_s.size(), 0.0),
                     std::vector<double>(pose_s.size(), 0.0)};
  std::size_t lo = 0;
  for (std::size_t i = 0; i < pose_s.size(); ++i) {
    while (lo < fix_s.size() && fix_s[lo] < pose_s[i] - 4.0 * kWindow) ++lo;
    double sw = 0.0, sw2 = 0.0, sv2 = 0.0;
    Eigen::Vector2d sr = Eigen::Vector2d::Zero();
    for (std::size_t j = lo; j < fix_s.size() && fix_s[j] <= pose_s[i] + 4.0 * kWindow; ++j) {
      const double d = (fix_s[j] - pose_s[i]) / kWindow;
      const double w = std::exp(-0.5 * d * d);
      sw += w, sw2 += w * w;
      sr += w * residual[j].head<2>();
      sv2 += w * residual[j].z() * residual[j].z();
    }
    if (sw < 1e-9) continue;  // no fix near: the walk's growth speaks
    out.mean_h2[i] = (sr / sw).squaredNorm() / 2.0;
    out.scatter_v2[i] = sv2 / sw / (sw * sw / sw2);
  }
  return out;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto k = static_cast<std::ptrdiff_t>(std::lround(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

SigmaStretch worstStretch(const Trajectory& poses, const std::vector<double>& h) {
  const auto top = static_cast<std::size_t>(std::max_element(h.begin(), h.end()) - h.begin());
  std::size_t a = top, b = top;
  while (a > 0 && h[a - 1] >= kStretchShare * h[top]) --a;
  while (b + 1 < h.size() && h[b + 1] >= kStretchShare * h[top]) ++b;
  return {poses[a].stamp, poses[b].stamp, h[top]};
}

void summarise(const Trajectory& poses, PoseSigmas& out) {
  out.median_h = quantile(out.h, 0.5);
  out.p95_h = quantile(out.h, 0.95);
  out.median_v = quantile(out.v, 0.5);
  out.worst = worstStretch(poses, out.h);
}

}  // namespace

PoseSigmas poseSigmas(const Trajectory& result, const Trajectory& aligned,
                      std::vector<SigmaFix> fixes) {
  PoseSigmas out;
  if (result.empty() || result.size() != aligned.size()) return out;
  const double first = result.front().stamp, last = result.back().stamp;
  fixes.erase(std::remove_if(fixes.begin(), fixes.end(),
                             [&](const SigmaFix& f) { return !(f.t >= first && f.t <= last); }),
              fixes.end());
  std::sort(fixes.begin(), fixes.end(),
            [](const SigmaFix& a, const SigmaFix& b) { return a.t < b.t; });
  out.fixes = fixes.size();
  const double inf = std::numeric_limits<double>::infinity();
  if (fixes.empty()) {
    out.h.assign(result.size(), inf);
    out.v.assign(result.size(), inf);
    summarise(result, out);
    return out;
  }
  // The path of the aligned SLAM (seconds count too) and of the result, at poses and fixes.
  std::vector<double> pose_along = pathLength(aligned);
  for (std::size_t i = 0; i < aligned.size(); ++i) {
    pose_along[i] += kTimeMetres * (aligned[i].stamp - first);
  }
  const std::vector<double> result_s = pathLength(result);
  const std::vector<Eigen::Vector3d> aligned_p = positions(aligned), result_p = positions(result);
  walk::Series axis[3];
  std::vector<double> fix_s;
  std::vector<Eigen::Vector3d> residual;
  std::size_t k1 = 0, k2 = 0, k3 = 0, k4 = 0;
  for (const SigmaFix& f : fixes) {
    const double along = at(aligned, pose_along, f.t, k1);
    const Eigen::Vector3d r = f.position - at(aligned, aligned_p, f.t, k2);
    for (int a = 0; a < 3; ++a) {
      const double sd = std::max(a < 2 ? f.std_h : f.std_v, 1e-3);
      axis[a].value.push_back(r[a]);
      axis[a].var.push_back(sd * sd);
      axis[a].along.push_back(along);
    }
    fix_s.push_back(at(result, result_s, f.t, k3));
    residual.push_back(f.position - at(result, result_p, f.t, k4));
  }
  out.walk_h = walk::learnIntensity({axis[0], axis[1]});
  out.walk_v = walk::learnIntensity({axis[2]});
  const std::vector<double> walk_h =
      toPoses(walk::smoothedVariance(axis[0], out.walk_h), axis[0].along, pose_along, out.walk_h);
  const std::vector<double> walk_v =
      toPoses(walk::smoothedVariance(axis[2], out.walk_v), axis[2].along, pose_along, out.walk_v);
  const LocalResiduals local = localResiduals(result_s, fix_s, residual);
  for (std::size_t i = 0; i < result.size(); ++i) {
    out.h.push_back(std::sqrt(kWalkH * kWalkH * walk_h[i] +
                              kMeanResidualH * kMeanResidualH * local.mean_h2[i]));
    out.v.push_back(
        std::sqrt(kWalkV * kWalkV * walk_v[i] + kScatterV * kScatterV * local.scatter_v2[i]));
  }
  summarise(result, out);
  return out;
}

}  // namespace flexcloud
