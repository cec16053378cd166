#include "flexcloud/fusion/fusion.h"

#include <ceres/ceres.h>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>

#include "flexcloud/fusion/clock_offset.h"
#include "flexcloud/fusion/fusion_factors.h"
#include "flexcloud/fusion/gnss_detail.h"
#include "flexcloud/fusion/slam_jitter.h"
#include "flexcloud/input/trajectory.h"
#include "flexcloud/metrics.h"
#include "flexcloud/sheet/alignment.h"
#include "parallel.h"

namespace flexcloud {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kMaxKeyframes = 1500;
constexpr double kRejectWeight = 0.1;     // a fix whose final weight is below this is an outlier
constexpr double kUnknownStdStart = 1.0;  // m, first guess for fixes without a std-dev
// The fused trajectory may leave the GNSS's inliers at this many times their own noise before
// the SLAM's noise is taken as set too low (over thousands of residuals a ratio of 1.5 is far
// beyond chance; the simulated drives stay at 0.73 or below, the real drive in
// ../shared/data/a2rl gives 1.8); rounds of raising it.
constexpr double kStiffSlam = 1.5;
constexpr int kNoiseRounds = 2;
constexpr double kMostNoiseStep = 2.0;
constexpr double kMinOffsetSigma = 0.005;    // s, tightest the speed profiles hold the offset
constexpr double kRestampTolerance = 0.001;  // s: a remainder beyond restamps the fixes
constexpr int kRestampRounds = 2;
// Relative change of the cost at which a solve stops: coarse for the stages (on a2rl 4-5
// iterations each instead of up to 21), fine for the last.
constexpr double kStageTolerance = 1e-3;
constexpr double kFinalTolerance = 1e-6;
// Iterations of the last solve, from the stages' solution: on a2rl it creeps on for 26 at 1e-6
// to a cost 0.4 % lower. 4 give the simulated drives' maps and trajectories and both real
// drives' leave-out within a centimetre of 10 iterations (scripts/accuracy.sh; every clock
// within 0.3 ms) at 0.06 s less on a2rl.
constexpr int kPolishIterations = 4;
// Iterations of a leave-out fold's solve, from the full solution: removing a fold's fixes moves
// the solution near them only, and Gauss-Newton's first steps take most of that.
constexpr int kLeaveOutIterations = 4;
constexpr int kJitterWindow = 10;  // fixes on either side for the SLAM's jitter
// Share of its jitter the SLAM's path may bend by per keyframe spacing (addOdometry). a2rl,
// every 10th fix held out, outside poses 306-358: 0 gives MAE / MAX 0.126 / 0.707 m, 0.5
// 0.102 / 0.569, 1 0.107 / 0.598; the simulated drives, whose SLAM barely jitters, keep their
// figures; monza's MAX, ruled by its chicanes, where the SLAM does not jitter, moves by
// +0.02 / +0.06 m (every 4th / 10th) at 0.5 and -0.02 / +0.14 m at 1.
constexpr double kJitterBend = 0.5;
constexpr double kGapAccel = 3.0;  // m/s^2: the change of speed a gap between poses hides
constexpr std::size_t kMinFixesForNoise = 10;  // fewer say nothing of the GNSS's noise
// Classes of fixes by their reported horizontal std-dev (m): RTK-fixed, float, worse. The
// reported std-devs of each class are scaled by what the drive shows of them.
constexpr double kClassBounds[] = {0.05, 0.5};
constexpr int kClasses = 3;
constexpr double kClassTolerance = 1.25;

using Vec3 = Eigen::Vector3d;

/// The SLAM noise model in SI units (per metre of path).
struct Noise {
  double rotation;     ///< rad / sqrt(m)
  double translation;  ///< m / sqrt(m)
  double rate;         ///< change of the rotation rate: rad/m / sqrt(m)
  double scale;        ///< change of the scale error: 1 / sqrt(m)
};

Noise noiseOf(const FusionOptions& p, double factor) {
  const double per_sqrt_km = factor / std::sqrt(1000.0);
  return {p.slam_rotation_noise * kDeg * per_sqrt_km, p.slam_translation_noise * per_sqrt_km,
          p.slam_drift_noise * kDeg / 1000.0 * per_sqrt_km,
          p.slam_scale_noise / 100.0 * per_sqrt_km};
}

/// The class of a fix by its reported std-dev (kClassBounds on the horizontal one).
int classOf(const Eigen::Vector3d& reported) {
  const double h = reported.head<2>().norm() / std::sqrt(2.0);
  int c = 0;
  while (c < kClasses - 1 && !(h < kClassBounds[c])) ++c;
  return c;
}

Eigen::Isometry3d isometry(const Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = p.orientation.toRotationMatrix();
  t.translation() = p.position;
  return t;
}

/// The SLAM pose at stamp t, interpolated between its neighbours (t within the poses' span).
Eigen::Isometry3d slamAt(const Trajectory& poses, double t) {
  const auto it = std::lower_bound(poses.begin(), poses.end(), t,
                                   [](const Pose& p, double s) { return p.stamp < s; });
  if (it == poses.begin()) return isometry(poses.front());
  if (it == poses.end()) return isometry(poses.back());
  const Pose& b = *it;
  const Pose& a = *(it - 1);
  const double f = (t - a.stamp) / std::max(1e-12, b.stamp - a.stamp);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = a.orientation.slerp(f, b.orientation).toRotationMatrix();
  out.translation() = a.position + f * (b.position - a.position);
  return out;
}

/// 1-sigma (m) of where the vehicle was at stamp t between the two SLAM poses around it, which
/// their linear interpolation cannot know: nothing at a pose's own stamp or between poses close
/// in time, up to half their distance apart across a long gap (a SLAM that keeps a pose every
/// few metres leaves a gap of seconds at every stop, and the car braked and started in it).
double gapSpread(const Trajectory& poses, double t) {
  const auto it = std::lower_bound(poses.begin(), poses.end(), t,
                                   [](const Pose& p, double s) { return p.stamp < s; });
  if (it == poses.begin() || it == poses.end()) return 0.0;
  const Pose& b = *it;
  const Pose& a = *(it - 1);
  // A change of speed at up to kGapAccel moves the vehicle from the interpolated place by at
  // most kGapAccel (t - ta) (tb - t) / 2, and never further than the poses lie apart.
  const double bound = kGapAccel * (t - a.stamp) * (b.stamp - t) / 2.0;
  return 0.5 * std::min(bound, (b.position - a.position).norm());
}

/// Keyframes every `spacing` metres of SLAM path (grown so there are at most kMaxKeyframes),
/// the first and last pose always; returns pose indices.
std::vector<std::size_t> chooseKeyframes(const Trajectory& poses, double spacing) {
  const std::vector<double> arc = arcLength(positionsOf(poses));
  spacing = std::max(spacing, arc.back() / static_cast<double>(kMaxKeyframes));
  std::vector<std::size_t> out{0};
  for (std::size_t i = 1; i + 1 < poses.size(); ++i) {
    if (arc[i] - arc[out.back()] >= spacing) out.push_back(i);
  }
  if (poses.size() > 1) out.push_back(poses.size() - 1);
  return out;
}

/// Geman-McClure on a squared, normalised residual s: rho = c^2 s / (c^2 + s). It redescends:
/// a residual far beyond c adds a bounded cost and no pull.
class GemanMcClure : public ceres::LossFunction {
 public:
  explicit GemanMcClure(double c) : c2_(c * c) {}
  void Evaluate(double s, double rho[3]) const override {
    const double d = c2_ + s;
    rho[0] = c2_ * s / d;
    rho[1] = c2_ * c2_ / (d * d);
    rho[2] = -2.0 * c2_ * c2_ / (d * d * d);
  }
  double weight(double s) const { return c2_ * c2_ / ((c2_ + s) * (c2_ + s)); }

 private:
  double c2_;
};

/// A weak prior that keeps a value near zero where nothing else determines it.
struct ZeroPrior {
  int n;
  double sigma;
  template <typename T>
  bool operator()(const T* x, T* r) const {
    for (int i = 0; i < n; ++i) r[i] = x[i] / T(sigma);
    return true;
  }
};

/// The clock offset stays near what the speed profiles showed.
struct OffsetPrior {
  double mean, sigma;
  template <typename T>
  bool operator()(const T* dt, T* r) const {
    r[0] = (dt[0] - T(mean)) / T(sigma);
    return true;
  }
};

/// The state of one keyframe: pose in ENU and drift.
struct Keyframe {
  std::size_t pose = 0;
  double q[4];  // x y z w
  double p[3];
  double w[3] = {0.0, 0.0, 0.0};
  double s = 0.0;
  Eigen::Isometry3d slam;
};

/// One fix prepared for the graph.
struct Fix {
  std::size_t input = 0;     ///< index into the GNSS list
  std::size_t keyframe = 0;  ///< index into the keyframes
  GnssFactor factor;
  bool known_std = true;
  /// Its std-dev (reported, or estimated where not given) with the SLAM's jitter and
  /// interpolation added.
  Vec3 own = Vec3::Zero();
  Vec3 jitter = Vec3::Zero();  ///< the SLAM's pose-to-pose error at its stamp (1-sigma)
  double gap = 0.0;            ///< the SLAM's interpolation at its stamp (1-sigma, m)
  Vec3 sigma = Vec3::Zero();   ///< what it is weighted with in the current stage
};

class Fusion {
 public:
  Fusion(const Trajectory& poses, const std::vector<GnssPoint>& gnss, const FusionOptions& options,
         const CancelToken& cancel, const LeaveOutFolds& folds)
      : poses_(poses),
        gnss_(gnss),
        options_(options),
        cancel_(cancel),
        folds_(folds),
        noise_(noiseOf(options, 1)),
        solver_threads_(threadCount(options.threads)) {}

  FusionResult run(const Eigen::Isometry3d& T_enu_map) {
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
    loss_ = std::make_shared<GemanMcClure>(options_.outlier_threshold);
    solveStages();
    adaptSlamNoise();
    restamp();
    holdClockWhereTheSpeedsDisagree();
    const auto full = polish();
    measureAtSolution(*full);
    collect();
    out_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out_;
  }

 private:
  void makeKeyframes(const Eigen::Isometry3d& T_enu_map) {
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

  bool excluded(double stamp) const {
    return std::any_of(options_.excluded_ranges.begin(), options_.excluded_ranges.end(),
                       [&](const TimeRange& r) { return r.contains(stamp); });
  }

  /// Decides which fixes take part: those whose instant on the SLAM's clock (stamp + shift_)
  /// lies within the poses' span and outside the excluded ranges, with a std-dev within the
  /// threshold.
  void selectFixes() {
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
      const double t = g.stamp + shift_;
      if (t < first || t > last) {
        o.verdict = FixVerdict::kOutsidePoses;
      } else if (excluded(t)) {
        o.verdict = FixVerdict::kExcluded;
      } else if (known && g.stdDev3d() > options_.stddev_threshold) {
        o.verdict = FixVerdict::kAboveThreshold;
      } else {
        Fix f;
        f.input = j;
        f.known_std = known;
        fixes_.push_back(f);
      }
    }
  }

  /// Ties every fix to the keyframe at or before its instant and makes its factor there; its
  /// SLAM jitter, and the std-devs it is weighted with (`unknown_*` for those without one).
  void prepareFixes(double unknown_h, double unknown_v) {
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

  void makeFactor(Fix& f, std::size_t k) const {
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
    f.factor.velocity = velocity;
    f.factor.fix = local(f);
    f.gap = gapSpread(poses_, t);
  }

  /// The SLAM's jitter at each fix (slam_jitter.h), from the fixes' residuals at the rigid
  /// start: a fix is compared with the SLAM's pose at its instant, and what the SLAM gets wrong
  /// from pose to pose weighs on that comparison as much as the GNSS's own noise.
  void measureJitter() {
    std::vector<Vec3> fix, slam;
    std::vector<double> stamps;
    for (const auto& f : fixes_) {
      fix.push_back(local(f));
      slam.push_back(start_ * slamAt(poses_, instantOf(f)) * out_.lever_arm);
      stamps.push_back(instantOf(f));
    }
    const std::vector<Vec3> j =
        slamJitter(fix, slam, stamps, kJitterWindow, options_.gnss_std_floor);
    for (std::size_t i = 0; i < fixes_.size(); ++i) fixes_[i].jitter = j[i];
  }

  /// The largest SLAM jitter (its 3D norm) of the fixes tied to each keyframe; 0 without any.
  std::vector<double> keyframeJitter() const {
    std::vector<double> out(keyframes_.size(), 0.0);
    for (const auto& f : fixes_) out[f.keyframe] = std::max(out[f.keyframe], f.jitter.norm());
    return out;
  }

  /// A fix's position in the graph's frame (origin_ subtracted).
  Vec3 local(const Fix& f) const { return gnss_[f.input].position - origin_; }

  /// A fix's instant on the SLAM's clock at the current estimate of the offset.
  double instantOf(const Fix& f) const { return gnss_[f.input].stamp + shift_ + dt_; }

  /// The rigid start fitted again to the fixes at their instants (robustRigidFit): with the
  /// clock off by half a second, a fit at the raw stamps is off by the distance the car
  /// covers in that time, along the track.
  void refitStart() {
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

  /// The std-dev a fix is weighted with: its own (reported, or the estimate for fixes
  /// without one), the SLAM's jitter and its interpolation at the fix's stamp.
  Vec3 sigmaOf(const Fix& f, double unknown_h, double unknown_v) const {
    const Vec3 s = ownSigma(gnss_[f.input].std_dev, unknown_h, unknown_v);
    return (s.cwiseProduct(s) + slamPart2(f)).cwiseSqrt();
  }

  /// The SLAM's own share of a fix's variance: its jitter and its interpolation, m^2.
  static Vec3 slamPart2(const Fix& f) {
    return f.jitter.cwiseProduct(f.jitter) + Vec3::Constant(f.gap * f.gap);
  }

  /// A fix's own std-dev: the reported one scaled by its class's factor, or the estimate for a
  /// fix without one; at least gnss_std_floor.
  Vec3 ownSigma(const Vec3& reported, double unknown_h, double unknown_v) const {
    const Vec3 s = reported.allFinite() ? Vec3(reported * class_scale_[classOf(reported)])
                                        : Vec3(unknown_h, unknown_h, unknown_v);
    return s.cwiseMax(options_.gnss_std_floor);
  }

  /// The graph with every `stride`-th fix (the keyframes and the SLAM in full).
  std::unique_ptr<ceres::Problem> makeProblem(std::size_t stride) {
    ceres::Problem::Options options;
    options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    auto problem = std::make_unique<ceres::Problem>(options);
    for (auto& k : keyframes_) problem->AddParameterBlock(k.q, 4, &quaternion_);
    addOdometry(*problem);
    Keyframe& k0 = keyframes_.front();
    problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<ZeroPrior, 3, 3>(new ZeroPrior{3, 1e-3}), nullptr, k0.w);
    problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<ZeroPrior, 1, 1>(new ZeroPrior{1, 0.05}), nullptr, &k0.s);
    problem->AddParameterBlock(&dt_, 1);
    if (out_.time_offset_held) {
      problem->SetParameterBlockConstant(&dt_);
    } else if (clock_.observable) {
      // A clock offset moves every fix along the track, and in a fit of positions a SLAM whose
      // heading wanders more than its noise says can pass for one (0.08 s, 1 m along the
      // track, on a drive without any). The speed profiles, which no rotation changes, set
      // it; the fixes refine it within the profiles' uncertainty.
      problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<OffsetPrior, 1, 1>(
              new OffsetPrior{clock_.offset - shift_, std::max(kMinOffsetSigma, clock_.sigma)}),
          nullptr, &dt_);
      // No bounds at max_time_offset here: with a bound on any block Ceres searches along
      // every step, a tenth of the fusion's time on a2rl; solveAt holds the offset instead.
    } else {
      problem->SetParameterBlockConstant(&dt_);  // none asked for, or the speed too even
    }
    for (std::size_t j = 0; j < fixes_.size(); j += stride) {
      Fix& f = fixes_[j];
      if (heldOut(f)) continue;
      Keyframe& k = keyframes_[f.keyframe];
      problem->AddResidualBlock(new GnssCost(f.factor), loss_.get(), k.q, k.p, &k.s, &dt_);
    }
    return problem;
  }

  void addOdometry(ceres::Problem& problem) {
    const std::vector<double> jitter = keyframeJitter();
    for (std::size_t i = 0; i + 1 < keyframes_.size(); ++i) {
      Keyframe& a = keyframes_[i];
      Keyframe& b = keyframes_[i + 1];
      const Eigen::Isometry3d rel = a.slam.inverse() * b.slam;
      const double d = std::max(0.01, rel.translation().norm());
      // Where the SLAM jitters, it struggles (a2rl: its height jumps 0.7 m from pose to pose
      // on a straight where it also leaves the RTK fixes by up to 0.9 m): there its path may
      // bend by a share of its jitter per keyframe spacing of path, on top of its usual noise.
      const double bend = kJitterBend * std::max(jitter[i], jitter[i + 1]) *
                          std::sqrt(d / std::max(options_.keyframe_spacing, 1.0));
      OdometryFactor f{rel.translation(), Eigen::Quaterniond(rel.linear()), d,
                       std::hypot(noise_.translation * std::sqrt(d), bend) + 1e-3,
                       noise_.rotation * std::sqrt(d) + 1e-6};
      problem.AddResidualBlock(new OdometryCost(f), nullptr, a.q, a.p, a.w, &a.s, b.q, b.p);
      const DriftFactor drift{noise_.rate * std::sqrt(d) + 1e-12,
                              noise_.scale * std::sqrt(d) + 1e-12};
      problem.AddResidualBlock(new DriftCost(drift), nullptr, a.w, &a.s, b.w, &b.s);
    }
  }

  /// Variance-component check of the SLAM's noise: the GNSS's inliers should stay from the
  /// fused trajectory within their own noise (the reported std-dev, or for fixes without one
  /// the roughness bound of the GNSS track, which does not depend on the SLAM). Where they stay
  /// further by a factor beyond kStiffSlam, the SLAM was held stiffer than it deserves (its
  /// errors were taken for GNSS noise and good fixes rejected): its noise is raised by that
  /// factor and the fusion solved again from the start.
  void adaptSlamNoise() {
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
      out_.slam_noise_scale =
          std::min(most, out_.slam_noise_scale * std::min(stiff, kMostNoiseStep));
      noise_ = noiseOf(options_, out_.slam_noise_scale);
      makeKeyframes(start_);
      dt_ = 0.0;
      unknown_h_ = unknown_v_ = kUnknownStdStart;
      for (auto& f : fixes_) f.own = sigmaOf(f, unknown_h_, unknown_v_);
      solveStages();
    }
  }

  /// Robust spread of the inliers' horizontal residuals in units of their own noise (1 when
  /// the fused trajectory leaves them as much as their noise says).
  double stiffness() const {
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

  /// The clock offset the speed profiles show, from the fixes that take part (a receiver's own
  /// large std-dev, as in an outage, would only add noise).
  /// The fixes are restamped by it (shift_): every fix's factor is made at its instant on the
  /// SLAM's clock, and the fusion's own offset (dt_) is what remains.
  void estimateClock() {
    std::vector<GnssPoint> taking_part;
    for (const auto& f : fixes_) taking_part.push_back(gnss_[f.input]);
    clock_ = estimateClockOffset(poses_, taking_part, options_.max_time_offset);
    shift_ = clock_.observable ? clock_.offset : 0.0;
    dt_ = 0.0;
  }

  bool heldOut(const Fix& f) const { return held_out_ >= 0 && (*holdout_)[f.input] == held_out_; }

  /// A copy of the fusion at its current solution, for a solve of its own beside this one:
  /// its factors weighted by its own fixes, its Ceres solves on one thread.
  Fusion copyForSolve() const {
    Fusion c(*this);
    for (Fix& f : c.fixes_) f.factor.sigma = &f.sigma;
    c.solver_threads_ = 1;
    return c;
  }

  /// Fold `k` of the leave-out solved again without its fixes from the current solution (the
  /// robust loss keeps its scale, the other fixes their weights), on a copy: each held-out
  /// fix's distance from the antenna that solve puts at its instant, into
  /// out_.leave_out_deviation.
  void leaveOutFold(int k) {
    Fusion fold = copyForSolve();
    fold.holdout_ = &folds_.fold;
    fold.held_out_ = k;
    std::size_t kept = 0, held = 0;
    for (const auto& f : fold.fixes_) (fold.heldOut(f) ? held : kept) += 1;
    if (held == 0 || kept < 3) return;
    fold.solveAt(*fold.makeProblem(1), 0.0, kLeaveOutIterations);
    for (const auto& f : fold.fixes_) {
      if (fold.heldOut(f)) out_.leave_out_deviation[f.input] = fold.residualOf(f).norm();
    }
  }

  /// What is measured at the solution and leaves it as it is, side by side: the offset's
  /// 1-sigma and the leave-out folds (each fold solves a copy).
  void measureAtSolution(ceres::Problem& full) {
    out_.leave_out_deviation.assign(gnss_.size(), std::numeric_limits<double>::quiet_NaN());
    const bool folds = folds_.folds >= 2 && folds_.fold.size() == gnss_.size();
    const std::size_t tasks = 1 + (folds ? static_cast<std::size_t>(folds_.folds) : 0);
    parallelRanges(tasks, tasks, options_.threads, [&](std::size_t task, std::size_t, std::size_t) {
      if (task > 0) {
        leaveOutFold(static_cast<int>(task) - 1);
      } else {
        offset_sigma_ = !clock_.observable      ? kInf
                        : out_.time_offset_held ? clock_.sigma
                                                : offsetSigma(full);
      }
    });
  }

  /// The last solve, to the fine tolerance: the heading of the fused trajectory, which the
  /// points beside it carry into the map, converges last. The problem is kept for what is
  /// measured at the solution.
  std::unique_ptr<ceres::Problem> polish() {
    auto full = makeProblem(1);
    solveAt(*full, 0.0, kPolishIterations, kFinalTolerance);
    return full;
  }

  /// 1-sigma of the clock offset at the solution, every other state free: the inverse of the
  /// Schur complement of the normal equations (robust loss applied) on the offset, widened by
  /// the fit's own spread where the residuals exceed their std-devs.
  double offsetSigma(ceres::Problem& problem) {
    ceres::Problem::EvaluateOptions eval;
    std::vector<double*> blocks;
    problem.GetParameterBlocks(&blocks);
    std::rotate(blocks.begin(), std::find(blocks.begin(), blocks.end(), &dt_), blocks.end());
    eval.parameter_blocks = blocks;  // the offset last
    double cost = 0.0;
    ceres::CRSMatrix crs;
    if (!problem.Evaluate(eval, &cost, nullptr, nullptr, &crs)) return kInf;
    const int n = crs.num_cols;
    std::vector<Eigen::Triplet<double>> entries;
    for (int r = 0; r < crs.num_rows; ++r) {
      for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
        entries.emplace_back(r, crs.cols[k], crs.values[k]);
      }
    }
    Eigen::SparseMatrix<double> j(crs.num_rows, n);
    j.setFromTriplets(entries.begin(), entries.end());
    const Eigen::SparseMatrix<double> h = j.transpose() * j;
    const Eigen::SparseMatrix<double> hxx = h.topLeftCorner(n - 1, n - 1);
    const Eigen::VectorXd hxd = h.block(0, n - 1, n - 1, 1);
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(hxx);
    if (ldlt.info() != Eigen::Success) return kInf;
    const double schur = h.coeff(n - 1, n - 1) - hxd.dot(ldlt.solve(hxd));
    if (!(schur > 0.0)) return kInf;
    const double dof = static_cast<double>(crs.num_rows - n);
    const double spread = dof > 0.0 ? std::max(1.0, 2.0 * cost / dof) : 1.0;
    return std::sqrt(spread / schur);
  }

  /// The clock to the millisecond: the factor moves a fix by velocity x dt_ (first order, off
  /// by acceleration x dt_^2 / 2), so while the remainder is more than kRestampTolerance the
  /// fixes are restamped by it, their factors, keyframes and jitter made again at their new
  /// instants, and the full problem solved again from where it stands.
  void restamp() {
    for (int round = 0; round < kRestampRounds; ++round) {
      if (!clock_.observable || !(std::abs(dt_) > kRestampTolerance)) break;
      solveRestampedAt(shift_ + dt_);
    }
  }

  /// The fixes restamped at `shift` (their factors, keyframes and jitter made again at their new
  /// instants, dt_ 0) and the full problem solved again from where it stands.
  void solveRestampedAt(double shift) {
    shift_ = shift;
    dt_ = 0.0;
    selectFixes();
    prepareFixes(unknown_h_, unknown_v_);
    const auto full = makeProblem(1);
    solveAt(*full, 0.0, 10);
  }

  /// Two measures of the clock: the speed profiles, which no shape error of the SLAM moves, and
  /// the fit of positions, which can take one for an offset. Where they disagree, the offset is
  /// held where heldClockOffset() says and the full problem solved again at it.
  void holdClockWhereTheSpeedsDisagree() {
    out_.time_offset_from_positions = shift_ + dt_;
    const std::optional<double> held = heldClockOffset(shift_ + dt_, clock_);
    if (!held) return;
    out_.time_offset_held = true;
    solveRestampedAt(*held);
  }

  /// Squared normalised residual of a fix at the current estimate.
  double squaredResidual(const Fix& f) const {
    const Keyframe& k = keyframes_[f.keyframe];
    double r[3];
    f.factor(k.q, k.p, &k.s, &dt_, r);
    return r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
  }

  /// Graduated non-convexity on the GNSS weights: every fix is first weighted as if its
  /// std-dev were at least a `floor` of metres, at which the SLAM's shape holds the trajectory
  /// and a slowly varying GNSS bias cannot bend it; the floor shrinks by 3 stage by stage down
  /// to the fixes' own std-devs, while the redescending loss (scale outlier_threshold, in units
  /// of the current std-dev) drops the fixes that stay far off. The std-devs of fixes without
  /// one are then estimated from the inliers and the last stages solved again.
  void solveStages() {
    std::vector<double> r0;
    for (const auto& f : fixes_) r0.push_back(residualOf(f).norm());
    double floor = std::max(1.0, median(std::move(r0)));
    // The stages decide which fixes are outliers; a few fixes per keyframe decide it as well as
    // all of them, at a fraction of the time on long drives. The last stages use every fix.
    const std::size_t stride = std::max<std::size_t>(1, fixes_.size() / (3 * keyframes_.size()));
    // A floor below every fix's own std-dev weights them as the full problem does: the
    // coarse stages end there.
    double tightest = std::numeric_limits<double>::infinity();
    for (const auto& f : fixes_) tightest = std::min(tightest, f.own.minCoeff());
    const double last = std::max(options_.gnss_std_floor, tightest);
    {
      const auto coarse = makeProblem(stride);
      for (; floor > last; floor /= 5.0) solveAt(*coarse, floor, 10);
    }
    const auto full = makeProblem(1);
    solveAt(*full, 0.0, 10);
    for (int round = 0; round < 3 && estimateUnknownStd(); ++round) solveAt(*full, 0.0, 20);
  }

  /// Solves from the current estimate, every fix weighted as if its std-dev were at least
  /// `floor`. The stages stop at a coarse tolerance (kStageTolerance): their result is the next
  /// stage's start, and only the last solve (polish) runs to kFinalTolerance.
  void solveAt(ceres::Problem& problem, double floor, int iterations,
               double tolerance = kStageTolerance) {
    cancel_.check("fusion");
    for (auto& f : fixes_) f.sigma = f.own.cwiseMax(floor);
    ceres::Solver::Options o;
    o.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    o.max_num_iterations = iterations;
    o.num_threads = solver_threads_;
    o.logging_type = ceres::SILENT;
    o.function_tolerance = tolerance;
    // Every stage starts near its solution (the previous stage's), where the problem is close
    // to quadratic: Ceres's default first trust region (1e4) held the steps back for up to 10
    // iterations per stage while it grew threefold per step; this one lets the first step be
    // nearly Gauss-Newton (scripts/accuracy.sh: the same figures within 0.02 m; a one-hour
    // drive's fusion 1.7 s before, 1.0 s after).
    o.initial_trust_region_radius = 1e8;

    ceres::Solver::Summary summary;
    ceres::Solve(o, &problem, &summary);
    int solves = 1;
    if (clampOffset()) {
      // Beyond the range asked for: the offset held at its bound, the rest solved again.
      problem.SetParameterBlockConstant(&dt_);
      ceres::Solve(o, &problem, &summary);
      problem.SetParameterBlockVariable(&dt_);
      ++solves;
    }
    if (held_out_ < 0) {
      ++out_.stages;
      out_.solves += solves;
    }
  }

  /// Moves the clock offset (shift_ + dt_) back within max_time_offset where a solve took it
  /// beyond; true if it did.
  bool clampOffset() {
    if (!clock_.observable) return false;
    const double bound = options_.max_time_offset;
    const double offset = shift_ + dt_;
    // Compared as the sum: (shift_ + dt_) - shift_ need not give dt_ back to the last bit, and
    // taken for a move it redid every solve.
    if (std::abs(offset) <= bound) return false;
    dt_ = std::clamp(offset, -bound, bound) - shift_;
    return true;
  }

  /// Sets the std-dev of the fixes without one to the robust spread of their inliers'
  /// residuals; true when it changed by more than a fifth (solve again). (Taken from all
  /// fixes, a fit-independent way or by maximum likelihood, it was tried and lost:
  /// doc/ACCURACY.md.)
  bool estimateUnknownStd() {
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
    const bool changed = std::abs(sh - unknown_h_) > 0.2 * unknown_h_ ||
                         std::abs(sv - unknown_v_) > 0.2 * unknown_v_;
    unknown_h_ = sh, unknown_v_ = sv;
    out_.estimated_std_h = sh;
    out_.estimated_std_v = sv;
    for (auto& f : fixes_) {
      if (!f.known_std) f.own = sigmaOf(f, sh, sv);
    }
    return changed;
  }

  /// Reported std-devs re-estimated from the drive, per class (kClassBounds): the white noise
  /// of the class's fixes less the SLAM at the rigid start (third divided differences of four
  /// consecutive fixes of the class at their stamps, where the SLAM takes the motion out; no fit
  /// is involved, whose residuals would shrink with the std-dev it assumes) in units of the
  /// std-dev they report, its Gaussian core (robustSigma: multipath and outliers have no part
  /// in it). That is the factor the class's std-devs are scaled by (0.5 to 100), where it is
  /// beyond kClassTolerance.
  void estimateClassScales() {
    std::vector<double> n[kClasses];
    for (std::size_t i = 0; i + 3 < fixes_.size(); ++i) {
      const int c = fixClass(fixes_[i]);
      bool same = c >= 0;
      for (std::size_t k = 1; same && k < 4; ++k) same = fixClass(fixes_[i + k]) == c;
      if (!same) continue;
      double t[4], reported = 0.0;
      Vec3 x[4];
      for (std::size_t k = 0; k < 4; ++k) {
        const Fix& f = fixes_[i + k];
        t[k] = instantOf(f);
        x[k] = local(f) - start_ * slamAt(poses_, t[k]) * out_.lever_arm;
        reported += 0.25 * gnss_[f.input].std_dev.head<2>().norm() / std::sqrt(2.0);
      }
      const std::optional<Vec3> d = thirdDividedDifference(x, t);
      if (!d || !(reported > 0.0)) continue;
      n[c].insert(n[c].end(), {d->x() / reported, d->y() / reported});
    }
    for (int c = 0; c < kClasses; ++c) {
      if (n[c].size() < 2 * kMinFixesForNoise) continue;
      const double scale = std::clamp(robustSigma(n[c], 1.0), 0.5, 100.0);
      // A receiver within a quarter of its word is taken at it.
      if (std::abs(std::log(scale)) > std::log(kClassTolerance)) class_scale_[c] = scale;
      out_.reported_std_scale[c] = class_scale_[c];
    }
    for (auto& f : fixes_) {
      if (f.known_std) f.own = f.sigma = sigmaOf(f, unknown_h_, unknown_v_);
    }
  }

  /// The class of a fix's reported std-dev; -1 for a fix without one.
  int fixClass(const Fix& f) const { return f.known_std ? classOf(gnss_[f.input].std_dev) : -1; }

  /// Residual of a fix in metres (ENU).
  Vec3 residualOf(const Fix& f) const {
    const Keyframe& k = keyframes_[f.keyframe];
    double r[3];
    f.factor(k.q, k.p, &k.s, &dt_, r);
    return Vec3(r[0], r[1], r[2]).cwiseProduct(f.sigma);
  }

  double weightOf(const Fix& f) const {
    return GemanMcClure(options_.outlier_threshold).weight(squaredResidual(f));
  }

  Eigen::Isometry3d keyframePose(const Keyframe& k) const {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = Eigen::Quaterniond(k.q[3], k.q[0], k.q[1], k.q[2]).normalized().toRotationMatrix();
    t.translation() = Vec3(k.p[0], k.p[1], k.p[2]);
    return t;
  }

  void collect() {
    std::vector<double> sigmas;
    for (const auto& f : fixes_) {
      FixOutcome& o = out_.fixes[f.input];
      o.error = -residualOf(f);  // the factor's residual is the fused antenna less the fix
      o.residual = o.error.norm();
      o.slam_jitter = f.jitter;
      o.slam_gap = f.gap;
      o.std_dev = ownSigma(gnss_[f.input].std_dev, unknown_h_, unknown_v_);
      o.weight = weightOf(f);
      o.verdict = o.weight < kRejectWeight ? FixVerdict::kOutlier : FixVerdict::kUsed;
      if (o.verdict == FixVerdict::kUsed) sigmas.push_back(f.sigma.x());
    }
    for (const auto& o : out_.fixes) {
      switch (o.verdict) {
        case FixVerdict::kUsed:
          ++out_.used;
          break;
        case FixVerdict::kOutlier:
          ++out_.outliers;
          break;
        case FixVerdict::kAboveThreshold:
          ++out_.above_threshold;
          break;
        case FixVerdict::kExcluded:
          ++out_.excluded;
          break;
        case FixVerdict::kOutsidePoses:
          ++out_.outside;
          break;
      }
    }
    if (!sigmas.empty()) out_.median_std_h = median(std::move(sigmas));
    if (unknown_h_ == kUnknownStdStart) {
      out_.estimated_std_h = out_.estimated_std_v = std::numeric_limits<double>::quiet_NaN();
    }
    out_.time_offset = shift_ + dt_;
    out_.time_offset_estimated = clock_.observable;
    out_.time_offset_from_speed = clock_.offset;
    out_.time_offset_speed_sigma = clock_.sigma;
    out_.time_offset_sigma = offset_sigma_;
    fusedPoses();
  }

  /// Every pose: its keyframe's fused pose, moved by the SLAM's motion since (scale applied).
  void fusedPoses() {
    out_.poses.resize(poses_.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < poses_.size(); ++i) {
      while (k + 1 < keyframes_.size() && keyframes_[k + 1].pose <= i) ++k;
      const Keyframe& key = keyframes_[k];
      Eigen::Isometry3d rel = key.slam.inverse() * isometry(poses_[i]);
      rel.translation() *= 1.0 + key.s;
      const Eigen::Isometry3d t = keyframePose(key) * rel;
      Pose& p = out_.poses[i];
      p.stamp = poses_[i].stamp;
      p.position = t.translation() + origin_;
      p.orientation = Eigen::Quaterniond(t.linear()).normalized();
    }
  }

  const Trajectory& poses_;
  const std::vector<GnssPoint>& gnss_;
  const FusionOptions options_;
  const CancelToken& cancel_;
  const LeaveOutFolds& folds_;
  /// The fold left out of the problems made now (-1: none), of the folds per input fix.
  int held_out_ = -1;
  const std::vector<int>* holdout_ = nullptr;
  Noise noise_;
  std::vector<Keyframe> keyframes_;
  std::vector<Fix> fixes_;
  Vec3 origin_ = Vec3::Zero();  ///< ENU of the graph's origin
  /// The rigid start: T_enu_map, in the graph's frame.
  Eigen::Isometry3d start_ = Eigen::Isometry3d::Identity();
  double shift_ = 0.0;          ///< s added to every fix's stamp before its factor is made
  double dt_ = 0.0;             ///< s, the fusion's estimate on top of shift_
  double offset_sigma_ = kInf;  ///< s, 1-sigma of shift_ + dt_
  ClockOffsetEstimate clock_;
  double unknown_h_ = kUnknownStdStart, unknown_v_ = kUnknownStdStart;
  double roughness_ = 0.0;
  double class_scale_[kClasses] = {1.0, 1.0, 1.0};  ///< factors on the reported std-devs

  std::shared_ptr<GemanMcClure> loss_;  ///< shared by the copies, which only read it
  int solver_threads_;                  ///< Ceres's threads per solve
  ceres::EigenQuaternionManifold quaternion_;
  FusionResult out_;
};

}  // namespace

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

FusionResult fuseTrajectory(const Trajectory& poses, const std::vector<GnssPoint>& gnss,
                            const Eigen::Isometry3d& T_enu_map, const FusionOptions& options,
                            const CancelToken& cancel, const LeaveOutFolds& folds) {
  if (poses.size() < 2) throw Error("fusion: at least 2 poses are needed");
  FusionResult out = Fusion(poses, gnss, options, cancel, folds).run(T_enu_map);
  takeGnssDetail(out);
  return out;
}

}  // namespace flexcloud
