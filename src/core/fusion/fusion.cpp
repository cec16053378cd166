// The fusion of SLAM and GNSS (fusion.h): its run and the set-up of its keyframes and fixes.
#include <algorithm>
#include <chrono>

#include "flexcloud/fusion/drive_ends.h"
#include "flexcloud/fusion/precise_follow.h"
#include "flexcloud/fusion/slam_jitter.h"
#include "flexcloud/input/trajectory.h"
#include "flexcloud/metrics.h"
#include "flexcloud/sheet/alignment.h"
#include "fusion_graph.h"

namespace flexcloud {
namespace fusion_graph {

FusionResult Fusion::run(const Eigen::Isometry3d& T_enu_map) {
  const auto t0 = std::chrono::steady_clock::now();
  out_.fixes.resize(gnss_.size());
  out_.lever_arm = options_.lever_arm;
  // The graph lives in a frame whose origin is the first fix: with the GNSS in UTM-size
  // coordinates the solver's relative tolerances would otherwise stop it centimetres short,
  // and a drive shifted by 4000 km would give another result.
  origin_ = gnss_.empty() ? Vec3::Zero() : gnss_.front().position;
  start_ = Eigen::Translation3d(-origin_) * T_enu_map;
  selectFixes();
  estimateClock();
  if (shift_ != 0.0) {
    // The fixes at their instants on the SLAM's clock, and the start fitted to them there.
    selectFixes();
    refitStart();
  }
  makeKeyframes(start_);
  prepareFixes(kUnknownStdStart, kUnknownStdStart);
  estimateClassScales();
  measureUnknownWhite();
  loss_ = std::make_shared<GemanMcClure>(options_.outlier_threshold);
  loss_imprecise_ =
      std::make_shared<GemanMcClure>(kImpreciseLoss * options_.outlier_threshold, true);
  solveStages();
  adaptSlamNoise();
  fitAntenna();
  reviewHeadingProfile();
  restamp();
  holdClockWhereTheSpeedsDisagree();
  leaveOutHeights();
  polish();
  // The fit of positions refines the offset within the profiles' sigma; their sigma stands,
  // for what the SLAM's lag puts into both (clock_offset.h), but where they knew it loosely:
  // there the fit decided it, and its own sigma is the offset's.
  offset_sigma_ = !clock_.observable ? kInf : out_.clock.loose ? fittedOffsetSigma() : clock_.sigma;
  collect();
  out_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out_;
}

void Fusion::makeKeyframes(const Eigen::Isometry3d& T_enu_map) {
  keyframes_.clear();
  for (std::size_t i : chooseKeyframes(poses_, options_.keyframe_spacing)) {
    Keyframe k;
    k.pose = i;
    k.slam = isometry(poses_[i]);
    const Eigen::Isometry3d t = T_enu_map * k.slam;
    const Eigen::Quaterniond q(t.linear());
    k.q[0] = q.x(), k.q[1] = q.y(), k.q[2] = q.z(), k.q[3] = q.w();
    for (int a = 0; a < 3; ++a) k.p[a] = t.translation()(a);
    keyframes_.push_back(k);
  }
  out_.keyframes = keyframes_.size();
}

bool Fusion::excluded(double stamp) const {
  return std::any_of(options_.excluded_ranges.begin(), options_.excluded_ranges.end(),
                     [&](const TimeRange& r) { return r.contains(stamp); });
}

void Fusion::selectFixes() {
  const double first = poses_.front().stamp, last = poses_.back().stamp;
  fixes_.clear();
  for (std::size_t j = 0; j < gnss_.size(); ++j) {
    const GnssPoint& g = gnss_[j];
    FixOutcome& o = out_.fixes[j];
    o = FixOutcome{};
    o.stamp = g.stamp;
    o.position = g.position;
    o.residual = std::numeric_limits<double>::quiet_NaN();
    const bool known = g.std_dev.allFinite();
    o.std_dev = known ? g.std_dev : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    o.std_given = known;
    const double t = g.stamp + shift_;
    if (t < first || t > last) {
      o.verdict = FixVerdict::kOutsidePoses;
    } else if (excluded(t)) {
      o.verdict = FixVerdict::kExcluded;
    } else if (known && g.stdDevH() > options_.stddev_threshold) {
      o.verdict = FixVerdict::kAboveThreshold;
    } else {
      Fix f;
      f.input = j;
      f.known_std = known;
      fixes_.push_back(f);
    }
  }
}

void Fusion::prepareFixes(double unknown_h, double unknown_v) {
  std::size_t k = 0;
  for (Fix& f : fixes_) {
    const double t = gnss_[f.input].stamp + shift_;
    while (k + 1 < keyframes_.size() && poses_[keyframes_[k + 1].pose].stamp <= t) ++k;
    makeFactor(f, k);
  }
  measureJitter();
  for (Fix& f : fixes_) {
    f.own = f.sigma = sigmaOf(f, unknown_h, unknown_v);
    f.factor.sigma = &f.sigma;  // fixes_ stays put until the next prepareFixes
  }
  if (fixes_.size() < 3) {
    throw Error("fusion: " + std::to_string(fixes_.size()) +
                " fixes can take part (std-dev within the threshold, inside the poses' time "
                "span and no excluded range), at least 3 are needed");
  }
}

void Fusion::makeFactor(Fix& f, std::size_t k) const {
  const Eigen::Isometry3d from = keyframes_[k].slam.inverse();
  const double t = gnss_[f.input].stamp + shift_;
  const Eigen::Isometry3d at = from * slamAt(poses_, t);
  const double h = 0.05;
  const Vec3 velocity = ((from * slamAt(poses_, t + h)).translation() -
                         (from * slamAt(poses_, t - h)).translation()) /
                        (2.0 * h);
  f.keyframe = k;
  f.factor.offset = at.translation();
  f.factor.antenna = at.linear() * out_.lever_arm;
  f.factor.axes = at.linear().leftCols<2>();
  f.factor.velocity = velocity;
  f.factor.fix = local(f);
  f.gap = gapSpread(poses_, t);
}

void Fusion::measureJitter() {
  std::vector<Vec3> fix, slam;
  std::vector<double> stamps;
  for (const auto& f : fixes_) {
    fix.push_back(local(f));
    slam.push_back(start_ * slamAt(poses_, instantOf(f)) * out_.lever_arm);
    stamps.push_back(instantOf(f));
  }
  const std::vector<Vec3> j = slamJitter(fix, slam, stamps, kJitterWindow, options_.gnss_std_floor);
  for (std::size_t i = 0; i < fixes_.size(); ++i) fixes_[i].jitter = j[i];
}

std::vector<double> Fusion::keyframeJitter() const {
  std::vector<double> out(keyframes_.size(), 0.0);
  for (const auto& f : fixes_) out[f.keyframe] = std::max(out[f.keyframe], f.jitter.norm());
  return out;
}

void Fusion::refitStart() {
  std::vector<Vec3> src, dst;
  for (const auto& f : fixes_) {
    src.push_back(slamAt(poses_, instantOf(f)) * out_.lever_arm);
    dst.push_back(local(f));
  }
  if (src.size() < 3) return;
  std::vector<double> w(src.size(), 1e-3);  // the path each fix stands for
  for (std::size_t i = 0; i < src.size(); ++i) {
    if (i > 0) w[i] += 0.5 * (src[i] - src[i - 1]).norm();
    if (i + 1 < src.size()) w[i] += 0.5 * (src[i + 1] - src[i]).norm();
  }
  start_ = robustRigidFit(src, dst, w).rigid();
}

Vec3 Fusion::sigmaOf(const Fix& f, double unknown_h, double unknown_v) const {
  const Vec3 s = ownSigma(gnss_[f.input].std_dev, unknown_h, unknown_v);
  return (s.cwiseProduct(s) + slamPart2(f)).cwiseSqrt();
}

Vec3 Fusion::slamPart2(const Fix& f) {
  return f.jitter.cwiseProduct(f.jitter) + Vec3::Constant(f.gap * f.gap);
}

Vec3 Fusion::ownSigma(const Vec3& reported, double unknown_h, double unknown_v) const {
  const Vec3 s = reported.allFinite() ? Vec3(reported * class_scale_[classOf(reported)])
                                      : Vec3(unknown_h, unknown_h, unknown_v);
  return s.cwiseMax(options_.gnss_std_floor);
}

}  // namespace fusion_graph

std::string toString(FixVerdict v) {
  switch (v) {
    case FixVerdict::kUsed:
      return "used";
    case FixVerdict::kOutlier:
      return "outlier";
    case FixVerdict::kAboveThreshold:
      return "above_std_threshold";
    case FixVerdict::kExcluded:
      return "excluded_range";
    case FixVerdict::kOutsidePoses:
      return "outside_poses";
  }
  return "?";
}

std::vector<std::size_t> judgedByStamp(const FusionResult& f) {
  std::vector<std::size_t> out;
  for (std::size_t j = 0; j < f.fixes.size(); ++j) {
    const FixVerdict v = f.fixes[j].verdict;
    if (v == FixVerdict::kUsed || v == FixVerdict::kOutlier) out.push_back(j);
  }
  std::stable_sort(out.begin(), out.end(), [&](std::size_t a, std::size_t b) {
    return f.fixes[a].stamp < f.fixes[b].stamp;
  });
  return out;
}

FusionResult fuseTrajectory(const Trajectory& poses, const std::vector<GnssPoint>& gnss,
                            const Eigen::Isometry3d& T_enu_map, const FusionOptions& options,
                            const CancelToken& cancel) {
  if (poses.size() < 2) throw Error("fusion: at least 2 poses are needed");
  const auto t0 = std::chrono::steady_clock::now();
  FusionResult out = fusion_graph::Fusion(poses, gnss, options, cancel).run(T_enu_map);
  // Where the profiles knew the offset loosely, the fit's offset stands as theirs would: told
  // from 0 and from a SLAM's own lag by its own sigma. Else the stamps as given, and the
  // fusion again with them (the urban KITTI drives as given: fitted 1-16 ms, none applied).
  if (out.clock.loose &&
      !beyondSlamLag(out.time_offset, out.time_offset_sigma, kClockSignificant)) {
    const Eigen::Vector2d fit(out.time_offset, out.time_offset_sigma);
    out = fusion_graph::Fusion(poses, gnss, options, cancel, fit).run(T_enu_map);
  }
  followPreciseGnss(out, FollowOptions{});
  followTheDrivesEnds(out);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace flexcloud
