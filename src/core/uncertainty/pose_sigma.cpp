#include "flexcloud/uncertainty/pose_sigma.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include "flexcloud/input/trajectory.h"
#include "uncertainty/random_walk.h"

namespace flexcloud {
namespace {

// Calibrated on the nine kitti_lo drives (RTK and urban GNSS) and the simulated drives against
// their truth (doc/ACCURACY.md): the weights of the walk's variance and of the local mean
// residual, horizontal and vertical. Vertically the squared mean residual counts beside the
// scatter: where the SLAM's height bends away from good fixes and the result keeps the bend
// (urban KITTI 02, 03, 07), the fixes near it agree with each other and not with the result.
constexpr double kWalkH = 1.25;
// Where the fixes near a pose are imprecise (beyond kImpreciseStd: urban GNSS), the horizontal
// walk's variance as learned, unweighted: with kWalkH, 98.9 % of the urban poses of kitti_lo and
// 99.3 % of mulran_lo's lay within 2.45 sigma (97.9 and 98.9 % now), and the simulated drives,
// whose fixes are precise but where none is near, keep kWalkH (open_gnss_late 89.7 % within,
// 85.6 % with this weight there too).
constexpr double kWalkImpreciseH = 1.0;
constexpr double kMeanResidualH = 0.95;
constexpr double kWalkV = 0.87;
constexpr double kScatterV = 0.66;
constexpr double kMeanResidualV = 1.0;
// Where the SLAM's white jitter was smoothed out of the result (jitter_smoothing.h) and the fixes
// are precise (RTK), the walk's weights, horizontal and of the vertical walk and scatter: the
// walk, learned from the fixes less the jittery SLAM, holds some of the jitter (what persists
// from one scan to the next, which the third differences do not see as white) that the
// smoothing took out. Calibrated on the KITTI RTK drives and the simulated ones with 1.5 cm of
// jitter (doc/ACCURACY.md). Full below kPreciseStd of the fixes' own 1-sigma (their weighted
// mean near the pose, the jitter included), none beyond kImpreciseStd, log-linear between.
constexpr double kWalkPreciseH = 0.6;
constexpr double kWalkPreciseV = 0.8;
constexpr double kSmoothedShare = 0.999;
constexpr double kPreciseStd = 0.05;   // m
constexpr double kImpreciseStd = 0.1;  // m
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

/// Horizontal speed at every pose (m/s), from its neighbours.
std::vector<double> speeds(const Trajectory& t) {
  std::vector<double> v(t.size(), 0.0);
  for (std::size_t i = 0; i < t.size(); ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1, b = std::min(i + 1, t.size() - 1);
    const double dt = t[b].stamp - t[a].stamp;
    if (dt > 0.0) v[i] = (t[b].position - t[a].position).head<2>().norm() / dt;
  }
  return v;
}

/// One axis of the correction's series: the fixes' residuals from the aligned SLAM with their
/// variances, and the poses as places without an observation, in path order; `pose_entry`
/// says where each pose went.
struct AxisSeries {
  walk::Series series;
  std::vector<std::size_t> pose_entry;
};

AxisSeries axisSeries(const std::vector<double>& fix_along, const std::vector<double>& fix_value,
                      const std::vector<double>& fix_var, const std::vector<double>& pose_along) {
  AxisSeries out;
  const double inf = std::numeric_limits<double>::infinity();
  std::size_t j = 0;
  for (std::size_t i = 0; i < pose_along.size(); ++i) {
    for (; j < fix_along.size() && fix_along[j] <= pose_along[i]; ++j) {
      out.series.value.push_back(fix_value[j]);
      out.series.var.push_back(fix_var[j]);
      out.series.along.push_back(fix_along[j]);
    }
    out.pose_entry.push_back(out.series.along.size());
    out.series.value.push_back(0.0);
    out.series.var.push_back(inf);
    out.series.along.push_back(pose_along[i]);
  }
  return out;
}

walk::Series fixSeries(const std::vector<double>& along, const std::vector<double>& value,
                       const std::vector<double>& var) {
  return {value, var, along};
}

/// The smoothed variance at the poses.
std::vector<double> atPoses(const AxisSeries& a, const walk::Intensity& q) {
  const std::vector<double> v = walk::smoothedVariance(a.series, q);
  std::vector<double> out;
  out.reserve(a.pose_entry.size());
  for (std::size_t e : a.pose_entry) out.push_back(v[e]);
  return out;
}

/// Near each pose (a Gaussian window along the result's path): the squared mean of the fixes'
/// horizontal residuals from the result, per axis, less what their own noise (`var_h`, per
/// axis) puts into such a mean (the walk's variance holds that already: counted here too, it
/// put 100 % of the poses of five urban KITTI drives within 2.45 sigma); the vertical
/// residuals' mean square over the window's effective number of fixes, and their squared mean
/// as it is (the vertical weights are calibrated with it: where the SLAM's height bends away
/// from the fixes, it is what tells).
struct LocalResiduals {
  std::vector<double> mean_h2, scatter_v2, mean_v2;
  std::vector<double> std_h;  ///< the fixes' own horizontal 1-sigma, their weighted mean
  /// The error the fixes share (SigmaFix::shared_*), the weighted mean of its squares.
  std::vector<double> shared_h2, shared_v2;
};

LocalResiduals localResiduals(const std::vector<double>& pose_s, const std::vector<double>& fix_s,
                              const std::vector<Eigen::Vector3d>& residual,
                              const std::vector<double>& var_h,
                              const std::vector<Eigen::Vector2d>& shared2) {
  const std::vector<double> zero(pose_s.size(), 0.0);
  LocalResiduals out{
      zero, zero, zero, std::vector<double>(pose_s.size(), std::numeric_limits<double>::infinity()),
      zero, zero};
  std::size_t lo = 0;
  for (std::size_t i = 0; i < pose_s.size(); ++i) {
    while (lo < fix_s.size() && fix_s[lo] < pose_s[i] - 4.0 * kWindow) ++lo;
    double sw = 0.0, sw2 = 0.0, sv2 = 0.0, sz = 0.0, noise_h = 0.0, sd = 0.0;
    Eigen::Vector2d sr = Eigen::Vector2d::Zero(), shared = Eigen::Vector2d::Zero();
    for (std::size_t j = lo; j < fix_s.size() && fix_s[j] <= pose_s[i] + 4.0 * kWindow; ++j) {
      const double d = (fix_s[j] - pose_s[i]) / kWindow;
      const double w = std::exp(-0.5 * d * d);
      sw += w, sw2 += w * w;
      sr += w * residual[j].head<2>();
      sv2 += w * residual[j].z() * residual[j].z();
      sz += w * residual[j].z();
      noise_h += w * w * var_h[j];
      sd += w * std::sqrt(var_h[j]);
      shared += w * shared2[j];
    }
    if (sw < 1e-9) continue;  // no fix near: the walk's growth speaks
    out.mean_h2[i] = std::max(0.0, (sr / sw).squaredNorm() - 2.0 * noise_h / (sw * sw)) / 2.0;
    out.scatter_v2[i] = sv2 / sw / (sw * sw / sw2);
    out.mean_v2[i] = (sz / sw) * (sz / sw);
    out.std_h[i] = sd / sw;
    out.shared_h2[i] = shared.x() / sw;
    out.shared_v2[i] = shared.y() / sw;
  }
  return out;
}

/// The weight `imprecise` where the fixes near a pose have a 1-sigma (`std_h`) beyond
/// kImpreciseStd, `precise` below kPreciseStd, log-linear between.
double weightFor(double std_h, double precise, double imprecise) {
  if (!(std_h > kPreciseStd)) return precise;
  if (std_h >= kImpreciseStd) return imprecise;
  const double u = std::log(std_h / kPreciseStd) / std::log(kImpreciseStd / kPreciseStd);
  return precise + u * (imprecise - precise);
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

/// The fixes moved from the antenna to the body, turned as the result's pose before them is.
void toBody(const Trajectory& result, const Eigen::Vector3d& lever, std::vector<SigmaFix>& fixes) {
  if (lever.isZero()) return;
  std::size_t k = 0;
  for (SigmaFix& f : fixes) {
    while (k + 1 < result.size() && result[k + 1].stamp <= f.t) ++k;
    f.position -= result[k].orientation * lever;
  }
}

/// The fixes on the poses' paths: their place on the aligned SLAM's path and the result's, their
/// residuals from the aligned SLAM (per axis) and from the trajectory the result `followed`
/// (the fused one; what the sheet left of it counts on its own), their variances.
struct FixTable {
  std::vector<double> along, result_s, x, y, z, var_h, var_v;
  std::vector<Eigen::Vector3d> residual;
  std::vector<Eigen::Vector2d> shared2;  ///< squared shared error, horizontal and vertical
};

FixTable fixTable(const std::vector<SigmaFix>& fixes, const Trajectory& result,
                  const Trajectory& followed, const Trajectory& aligned,
                  const std::vector<double>& pose_along, double slam_white) {
  FixTable t;
  const std::vector<double> result_s = pathLength(result);
  const std::vector<Eigen::Vector3d> aligned_p = positionsOf(aligned),
                                     followed_p = positionsOf(followed);
  std::size_t k1 = 0, k2 = 0, k3 = 0, k4 = 0;
  for (const SigmaFix& f : fixes) {
    t.along.push_back(at(aligned, pose_along, f.t, k1));
    const Eigen::Vector3d r = f.position - at(aligned, aligned_p, f.t, k2);
    t.x.push_back(r.x()), t.y.push_back(r.y()), t.z.push_back(r.z());
    t.var_h.push_back(std::pow(std::max(f.std_h, 1e-3), 2) + slam_white * slam_white);
    t.var_v.push_back(std::pow(std::max(f.std_v, 1e-3), 2));
    t.result_s.push_back(at(result, result_s, f.t, k3));
    t.residual.push_back(f.position - at(followed, followed_p, f.t, k4));
    t.shared2.emplace_back(f.shared_h * f.shared_h, f.shared_v * f.shared_v);
  }
  return t;
}

/// The fixes the result rests on: all but the disputed.
std::vector<SigmaFix> restingOn(const std::vector<SigmaFix>& fixes) {
  std::vector<SigmaFix> out;
  std::copy_if(fixes.begin(), fixes.end(), std::back_inserter(out),
               [](const SigmaFix& f) { return !f.disputed; });
  return out;
}

/// What the sigmas of the poses are made of (poseSigmas).
struct Terms {
  std::vector<double> walk_h, walk_v;
  LocalResiduals local;
};

/// Every pose's sigmas from `terms`, the sheet's departure from the fused trajectory, the SLAM's
/// jitter left in it and the speed times the clock's sigma (SigmaContext).
void combine(const Trajectory& result, const Terms& terms, const SigmaContext& context,
             PoseSigmas& out) {
  const std::vector<double> v = speeds(result);
  const Trajectory* fused =
      context.fused != nullptr && context.fused->size() == result.size() ? context.fused : nullptr;
  for (std::size_t i = 0; i < result.size(); ++i) {
    // What the sheet left of the fused trajectory adds in full.
    const Eigen::Vector3d sheet = fused != nullptr
                                      ? Eigen::Vector3d(result[i].position - (*fused)[i].position)
                                      : Eigen::Vector3d::Zero();
    const double jitter =
        context.jitter != nullptr && i < context.jitter->size() ? (*context.jitter)[i] : 0.0;
    // Smoothed: less of the SLAM's jitter left than it showed.
    const bool smoothed = jitter < kSmoothedShare * context.slam_white;
    const LocalResiduals& local = terms.local;
    // No fix near (std_h infinite): the weight the walk's growth was calibrated with.
    const double imprecise = std::isfinite(local.std_h[i]) ? kWalkImpreciseH : kWalkH;
    const double wh = weightFor(local.std_h[i], smoothed ? kWalkPreciseH : kWalkH, imprecise);
    const double wv = smoothed ? weightFor(local.std_h[i], kWalkPreciseV, 1.0) : 1.0;
    // What the fixes know of the pose, at least the error they share.
    const double known_h = std::max(wh * wh * terms.walk_h[i], local.shared_h2[i]);
    const double known_v = std::max(
        wv * wv * (kWalkV * kWalkV * terms.walk_v[i] + kScatterV * kScatterV * local.scatter_v2[i]),
        local.shared_v2[i]);
    // The clock's error moves a pose along the track: one of the two horizontal axes. Held at
    // the stamps as given, it hides in imprecise fixes' noise, but not beyond what they leave
    // of the pose unknown (the variance at most doubled): more would show where the drive turns.
    const double held = weightFor(local.std_h[i], 0.0, 1.0) *
                        std::min(v[i] * context.held_clock_sigma, std::sqrt(2.0 * known_h));
    const double clock =
        std::hypot(std::hypot(v[i] * context.clock_sigma, held), context.antenna_sigma);
    out.h.push_back(std::sqrt(known_h + kMeanResidualH * kMeanResidualH * local.mean_h2[i] +
                              sheet.head<2>().squaredNorm() / 2.0 + clock * clock / 2.0 +
                              jitter * jitter));
    out.v.push_back(std::sqrt(known_v + kMeanResidualV * kMeanResidualV * local.mean_v2[i] +
                              sheet.z() * sheet.z()));
  }
}

}  // namespace

PoseSigmas poseSigmas(const Trajectory& result, const Trajectory& aligned,
                      std::vector<SigmaFix> fixes, const SigmaContext& context) {
  PoseSigmas out;
  if (result.empty() || result.size() != aligned.size()) return out;
  const double first = result.front().stamp, last = result.back().stamp;
  fixes.erase(std::remove_if(fixes.begin(), fixes.end(),
                             [&](const SigmaFix& f) { return !(f.t >= first && f.t <= last); }),
              fixes.end());
  std::sort(fixes.begin(), fixes.end(),
            [](const SigmaFix& a, const SigmaFix& b) { return a.t < b.t; });
  toBody(result, context.lever_arm, fixes);
  const std::vector<SigmaFix> rest = restingOn(fixes);
  out.fixes = rest.size();
  if (rest.empty()) {
    out.h.assign(result.size(), std::numeric_limits<double>::infinity());
    out.v = out.h;
    summarise(result, out);
    return out;
  }
  // The path of the aligned SLAM (seconds count too): where the walk takes its steps.
  std::vector<double> pose_along = pathLength(aligned);
  for (std::size_t i = 0; i < aligned.size(); ++i) {
    pose_along[i] += kTimeMetres * (aligned[i].stamp - first);
  }
  const bool fused = context.fused != nullptr && context.fused->size() == result.size();
  const Trajectory& followed = fused ? *context.fused : result;
  const FixTable t = fixTable(rest, result, followed, aligned, pose_along, context.slam_white);
  // The local residuals count the disputed fixes too: a table of their own only where any are.
  const bool any_disputed = rest.size() < fixes.size();
  const FixTable disputed_too =
      any_disputed ? fixTable(fixes, result, followed, aligned, pose_along, context.slam_white)
                   : FixTable{};
  const FixTable& all = any_disputed ? disputed_too : t;
  const AxisSeries x = axisSeries(t.along, t.x, t.var_h, pose_along);
  const AxisSeries z = axisSeries(t.along, t.z, t.var_v, pose_along);
  // Learned from the fixes alone: the poses' places add nothing to the likelihood.
  const walk::Intensity qh =
      walk::learnIntensity({fixSeries(t.along, t.x, t.var_h), fixSeries(t.along, t.y, t.var_h)});
  const walk::Intensity qv = walk::learnIntensity({fixSeries(t.along, t.z, t.var_v)});
  out.walk_h = qh.value, out.walk_rate_h = qh.rate;
  out.walk_v = qv.value, out.walk_rate_v = qv.rate;
  const Terms terms{
      atPoses(x, qh), atPoses(z, qv),
      localResiduals(pathLength(result), all.result_s, all.residual, all.var_h, all.shared2)};
  combine(result, terms, context, out);
  summarise(result, out);
  return out;
}

}  // namespace flexcloud
