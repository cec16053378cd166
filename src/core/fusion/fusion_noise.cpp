// The fusion's noise from the drive: the SLAM's, the std-devs of fixes without one, the reported
// ones by class.
#include <algorithm>
#include <optional>

#include "flexcloud/fusion/slam_jitter.h"
#include "flexcloud/metrics.h"
#include "fusion_graph.h"

namespace flexcloud {
namespace fusion_graph {

void Fusion::adaptSlamNoise() {
  std::vector<Vec3> track;
  std::vector<double> stamps;
  for (const auto& f : fixes_) {
    track.push_back(f.factor.fix);
    stamps.push_back(instantOf(f));
  }
  roughness_ = std::max(options_.gnss_std_floor, roughness(track, stamps).x());  // horizontal
  out_.gnss_roughness_h = roughness_;
  for (int round = 0; round < kNoiseRounds; ++round) {
    const double stiff = stiffness();
    const double most = options_.max_slam_noise_scale;
    if (!(stiff > kStiffSlam) || out_.slam_noise_scale >= most) return;
    // A step of at most kMostNoiseStep per round: a large ratio says as much of errors of the
    // GNSS that are smooth (multipath, which no roughness shows) as of the SLAM's.
    out_.slam_noise_scale = std::min(most, out_.slam_noise_scale * std::min(stiff, kMostNoiseStep));
    noise_ = noiseOf(options_, out_.slam_noise_scale);
    solveFromStart();
  }
}

void Fusion::solveFromStart() {
  makeKeyframes(start_);
  dt_ = 0.0;
  unknown_h_ = start_unknown_h_, unknown_v_ = start_unknown_v_;
  for (auto& f : fixes_) f.own = sigmaOf(f, unknown_h_, unknown_v_);
  solveStages();
}

void Fusion::measureUnknownWhite() {
  std::vector<Vec3> track, less;
  std::vector<double> stamps;
  for (const auto& f : fixes_) {
    if (f.known_std) continue;
    track.push_back(local(f));
    less.push_back(local(f) - start_ * slamAt(poses_, instantOf(f)) * out_.lever_arm);
    stamps.push_back(instantOf(f));
  }
  if (track.size() < kMinFixesForNoise) return;
  const Eigen::Vector2d r = calmRoughness(track, stamps).cwiseMin(calmRoughness(less, stamps));
  out_.unknown_white = r.cwiseMax(kLeastWhite);
  if (!(r.x() >= kPreciseStd)) return;
  // Code-grade fixes: the stages anneal down to their noise, not to a metre; at a metre every
  // multipath episode of one or two metres keeps its pull (KITTI 07 with 0.3 m urban GNSS:
  // the fused trajectory 0.72 m off the truth, 0.24 m so).
  unknown_h_ = start_unknown_h_ = std::max(options_.gnss_std_floor, r.x());
  unknown_v_ = start_unknown_v_ = std::max(options_.gnss_std_floor, r.y());
  for (auto& f : fixes_) {
    if (!f.known_std) f.own = f.sigma = sigmaOf(f, unknown_h_, unknown_v_);
  }
}

double Fusion::stiffness() const {
  std::vector<double> n;
  for (const auto& f : fixes_) {
    if (weightOf(f) < 0.5) continue;
    const Vec3 e = residualOf(f);
    const double own =
        f.known_std ? f.own.x() : std::sqrt(roughness_ * roughness_ + slamPart2(f).x());
    n.push_back(std::abs(e.x() / own));
    n.push_back(std::abs(e.y() / own));
  }
  if (n.size() < 2 * kMinFixesForNoise) return 1.0;
  return median(std::move(n)) / 0.6745;  // median |N(0, 1)|
}

bool Fusion::estimateUnknownStd() {
  std::vector<double> h, v;
  for (const auto& f : fixes_) {
    if (f.known_std || weightOf(f) < 0.5) continue;
    // The GNSS's own part of the residual: the SLAM's jitter and interpolation taken out.
    const Vec3 e = residualOf(f), j2 = slamPart2(f);
    h.push_back(std::sqrt(std::max(0.0, 0.5 * (e.x() * e.x() + e.y() * e.y()) - j2.x())));
    v.push_back(std::sqrt(std::max(0.0, e.z() * e.z() - j2.z())));
  }
  if (h.size() < kMinFixesForNoise) return false;
  const double sh = std::max(options_.gnss_std_floor, 1.4826 * median(h));  // a 1-sigma
  const double sv = std::max(options_.gnss_std_floor, 1.4826 * median(v));
  const bool changed =
      std::abs(sh - unknown_h_) > 0.2 * unknown_h_ || std::abs(sv - unknown_v_) > 0.2 * unknown_v_;
  unknown_h_ = sh, unknown_v_ = sv;
  out_.estimated_std_h = sh;
  out_.estimated_std_v = sv;
  for (auto& f : fixes_) {
    if (!f.known_std) f.own = sigmaOf(f, sh, sv);
  }
  return changed;
}

void Fusion::estimateClassScales() {
  // Two upper bounds of each class's white noise: the fixes less the SLAM (the SLAM's own
  // jitter adds to it) and the fixes alone (the motion's jerk adds to it); the smaller holds.
  std::vector<double> n[kClasses], alone[kClasses];
  for (std::size_t i = 0; i + 3 < fixes_.size(); ++i) {
    const int c = fixClass(fixes_[i]);
    bool same = c >= 0;
    for (std::size_t k = 1; same && k < 4; ++k) same = fixClass(fixes_[i + k]) == c;
    if (!same) continue;
    double t[4], reported = 0.0;
    Vec3 x[4], g[4];
    for (std::size_t k = 0; k < 4; ++k) {
      const Fix& f = fixes_[i + k];
      t[k] = instantOf(f);
      g[k] = local(f);
      x[k] = g[k] - start_ * slamAt(poses_, t[k]) * out_.lever_arm;
      reported += 0.25 * gnss_[f.input].std_dev.head<2>().norm() / std::sqrt(2.0);
    }
    const std::optional<Vec3> d = thirdDividedDifference(x, t);
    const std::optional<Vec3> da = thirdDividedDifference(g, t);
    if (!d || !da || !(reported > 0.0)) continue;
    n[c].insert(n[c].end(), {d->x() / reported, d->y() / reported});
    alone[c].insert(alone[c].end(), {da->x() / reported, da->y() / reported});
  }
  for (int c = 0; c < kClasses; ++c) {
    if (n[c].size() < 2 * kMinFixesForNoise) continue;
    const double scale =
        std::clamp(std::min(robustSigma(n[c], 1.0), robustSigma(alone[c], 1.0)), 0.5, 100.0);
    // A receiver within a quarter of its word is taken at it.
    if (std::abs(std::log(scale)) > std::log(kClassTolerance)) class_scale_[c] = scale;
    out_.reported_std_scale[c] = class_scale_[c];
  }
  for (auto& f : fixes_) {
    if (f.known_std) f.own = f.sigma = sigmaOf(f, unknown_h_, unknown_v_);
  }
}

}  // namespace fusion_graph
}  // namespace flexcloud
