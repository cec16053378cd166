/// The fusion's graph, private to src/core/fusion: its constants, keyframes and fixes, and the
/// Fusion class whose members are defined by task in fusion.cpp (set-up), fusion_problem.cpp
/// (the Ceres problem and its solves), fusion_noise.cpp (noise from the drive),
/// fusion_clock.cpp (the clock offset) and fusion_measure.cpp (results).
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "ceres_compat.h"
#include "flexcloud/cancel.h"
#include "flexcloud/fusion/clock_offset.h"
#include "flexcloud/fusion/fusion.h"
#include "flexcloud/fusion/fusion_factors.h"
#include "parallel.h"

namespace flexcloud {
namespace fusion_graph {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kMaxKeyframes = 1500;
constexpr double kRejectWeight = 0.1;     // a fix whose final weight is below this is an outlier
constexpr double kUnknownStdStart = 1.0;  // m, first guess for fixes without a std-dev
// The fused trajectory may leave the GNSS's inliers at this many times their own noise before
// the SLAM's noise is taken as set too low (over thousands of residuals a ratio of 1.5 is far
// beyond chance); rounds of raising it. It reads the inliers only, and since each fix's noise
// holds the SLAM's jitter it fires seldom: of the drives here on urban_keyframes_1hz seed 3
// alone (x2); a2rl reads 0.47, monza 0.99, and loop_rtk with the SLAM's noise set 100 times
// too low 0.85 (doc/ACCURACY.md).
constexpr double kStiffSlam = 1.5;
constexpr int kNoiseRounds = 2;
constexpr double kMostNoiseStep = 2.0;
// m: the prior on the antenna's offset from the poses' origin where none was given; it keeps
// the offset near 0 where the drive cannot show it (a straight, where it moves every fix as a
// shift of the whole track does).
constexpr double kLeverSigma = 2.0;
// An estimated offset is kept where it is told from 0 by this many times its sigma along the
// direction of travel, where a clock offset would move the fixes as it does. The six MulRan
// drives (antenna 1.26-1.97 m from the LiDAR) tell it by 113-310 sigma with RTK GNSS and 17-28
// with urban GNSS, the KITTI drives (truth within 0.1 m of the LiDAR) by 0.4-2.4 (urban).
constexpr double kLeverTold = 5.0;
constexpr double kMinOffsetSigma = 0.005;    // s, tightest the speed profiles hold the offset
constexpr double kTiltSigma = 2.0 * kDeg;    // the keyframes' mean tilt about the start's
constexpr double kRestampTolerance = 0.001;  // s: a remainder beyond restamps the fixes
constexpr double kOffsetProbe = 0.01;        // s: the offset's moves for its fitted sigma
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
// m: fixes whose own horizontal std-dev is below this see the SLAM's short-term errors.
constexpr double kPreciseStd = 0.1;
constexpr double kLeastWhite = 1e-3;          // m, the least white noise taken from a roughness
constexpr double kImpreciseLoss = 4.0 / 3.0;  // see below
// Code-grade fixes (kPreciseStd or worse) are weighed with Tukey's biweight at this many times
// outlier_threshold, which gives a fix beyond it no pull at all: under Geman-McClure a
// multipath episode of two or three metres in 0.3 m GNSS kept a fifth of its weight and drew
// the fused trajectory 0.5-1 m toward it (KITTI 03, 09 with urban GNSS: 0.48 / 0.45 m against
// the truth, 0.36 / 0.38 m so). RTK-grade fixes keep Geman-McClure: under Tukey's loss the
// simulated drives with varying drift lost up to 2x.

using Vec3 = Eigen::Vector3d;

/// The SLAM noise model in SI units (per metre of path).
struct Noise {
  double rotation;     ///< rad / sqrt(m)
  double translation;  ///< m / sqrt(m)
  double rate;         ///< change of the rotation rate: rad/m / sqrt(m)
  double scale;        ///< change of the scale error: 1 / sqrt(m)
};

Noise noiseOf(const FusionOptions& p, double factor);

/// The class of a fix by its reported std-dev (kClassBounds on the horizontal one).
int classOf(const Eigen::Vector3d& reported);

Eigen::Isometry3d isometry(const Pose& p);

/// The SLAM pose at stamp t, interpolated between its neighbours (t within the poses' span).
Eigen::Isometry3d slamAt(const Trajectory& poses, double t);

/// 1-sigma (m) of where the vehicle was at stamp t between the two SLAM poses around it, which
/// their linear interpolation cannot know: nothing at a pose's own stamp or between poses close
/// in time, up to half their distance apart across a long gap (a SLAM that keeps a pose every
/// few metres leaves a gap of seconds at every stop, and the car braked and started in it).
double gapSpread(const Trajectory& poses, double t);

/// m/s: the spread of the horizontal velocities across the drive's main direction (the smaller
/// axis of their covariance); below kLeastTurn the drive is a straight.
double crossSpeedSpread(const Trajectory& poses);

/// Keyframes every `spacing` metres of SLAM path (grown so there are at most kMaxKeyframes),
/// the first and last pose always; returns pose indices.
std::vector<std::size_t> chooseKeyframes(const Trajectory& poses, double spacing);

/// Geman-McClure on a squared, normalised residual s: rho = c^2 s / (c^2 + s). It redescends:
/// a residual far beyond c adds a bounded cost and no pull.
class GemanMcClure : public ceres::LossFunction {
 public:
  /// With `tukey`, Tukey's biweight of scale c instead: no pull at all beyond it.
  explicit GemanMcClure(double c, bool tukey = false) : c2_(c * c), tukey_(tukey) {}
  bool tukey() const { return tukey_; }
  void Evaluate(double s, double rho[3]) const override {
    if (tukey_) {
      if (s >= c2_) {
        rho[0] = c2_ / 3.0, rho[1] = 0.0, rho[2] = 0.0;
        return;
      }
      const double u = 1.0 - s / c2_;
      rho[0] = c2_ / 3.0 * (1.0 - u * u * u);
      rho[1] = u * u;
      rho[2] = -2.0 * u / c2_;
      return;
    }
    const double d = c2_ + s;
    rho[0] = c2_ * s / d;
    rho[1] = c2_ * c2_ / (d * d);
    rho[2] = -2.0 * c2_ * c2_ / (d * d * d);
  }
  double weight(double s) const {
    if (tukey_) return s >= c2_ ? 0.0 : (1.0 - s / c2_) * (1.0 - s / c2_);
    return c2_ * c2_ / ((c2_ + s) * (c2_ + s));
  }

 private:
  double c2_;
  bool tukey_;
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

/// A keyframe's tilt stays near the start's: `up` is the body's direction the start put up; its
/// horizontal part after the keyframe's rotation, over sigma (rad).
struct TiltPrior {
  Eigen::Vector3d up;
  double sigma;
  template <typename T>
  bool operator()(const T* q, T* r) const {
    const Eigen::Quaternion<T> rot(q[3], q[0], q[1], q[2]);
    const Eigen::Matrix<T, 3, 1> u = rot.normalized() * up.cast<T>();
    r[0] = u.x() / T(sigma);
    r[1] = u.y() / T(sigma);
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
  bool imprecise = false;      ///< its own std-dev is kPreciseStd or worse: Tukey's loss
  /// Its height left out (leaveOutHeights()): its horizontal part alone takes part.
  bool level_only = false;
};

class Fusion {
 public:
  /// `loose_fit`: a run before found the offset loosely known and its fit of positions not
  /// told from 0 or a SLAM's own lag (offset, 1-sigma, s): this one keeps the stamps as given.
  Fusion(const Trajectory& poses, const std::vector<GnssPoint>& gnss, const FusionOptions& options,
         const CancelToken& cancel, std::optional<Eigen::Vector2d> loose_fit = std::nullopt)
      : poses_(poses),
        gnss_(gnss),
        options_(options),
        cancel_(cancel),
        loose_fit_(loose_fit),
        noise_(noiseOf(options, 1)),
        solver_threads_(threadCount(options.threads)) {}

  FusionResult run(const Eigen::Isometry3d& T_enu_map);

 private:
  void makeKeyframes(const Eigen::Isometry3d& T_enu_map);

  bool excluded(double stamp) const;

  /// Decides which fixes take part: those whose instant on the SLAM's clock (stamp + shift_)
  /// lies within the poses' span and outside the excluded ranges, with a std-dev within the
  /// threshold.
  void selectFixes();

  /// Ties every fix to the keyframe at or before its instant and makes its factor there; its
  /// SLAM jitter, and the std-devs it is weighted with (`unknown_*` for those without one).
  void prepareFixes(double unknown_h, double unknown_v);

  void makeFactor(Fix& f, std::size_t k) const;

  /// The SLAM's jitter at each fix (slam_jitter.h), from the fixes' residuals at the rigid
  /// start: a fix is compared with the SLAM's pose at its instant, and what the SLAM gets wrong
  /// from pose to pose weighs on that comparison as much as the GNSS's own noise.
  void measureJitter();

  /// The largest SLAM jitter (its 3D norm) of the fixes tied to each keyframe; 0 without any.
  std::vector<double> keyframeJitter() const;

  /// A fix's position in the graph's frame (origin_ subtracted).
  Vec3 local(const Fix& f) const { return gnss_[f.input].position - origin_; }

  /// A fix's instant on the SLAM's clock at the current estimate of the offset.
  double instantOf(const Fix& f) const { return gnss_[f.input].stamp + shift_ + dt_; }

  /// The rigid start fitted again to the fixes at their instants (robustRigidFit): with the
  /// clock off by half a second, a fit at the raw stamps is off by the distance the car
  /// covers in that time, along the track.
  void refitStart();

  /// The std-dev a fix is weighted with: its own (reported, or the estimate for fixes
  /// without one), the SLAM's jitter and its interpolation at the fix's stamp.
  Vec3 sigmaOf(const Fix& f, double unknown_h, double unknown_v) const;

  /// The SLAM's own share of a fix's variance: its jitter and its interpolation, m^2.
  static Vec3 slamPart2(const Fix& f);

  /// The white noise of the fixes without a std-dev, from their roughness
  /// (FusionResult::unknown_white). Where they are code-grade (kPreciseStd or worse) their
  /// std-dev starts there instead of at kUnknownStdStart.
  void measureUnknownWhite();

  /// A fix's own std-dev: the reported one scaled by its class's factor, or the estimate for a
  /// fix without one; at least gnss_std_floor.
  Vec3 ownSigma(const Vec3& reported, double unknown_h, double unknown_v) const;

  /// The graph with every `stride`-th fix (the keyframes and the SLAM in full).
  std::unique_ptr<ceres::Problem> makeProblem(std::size_t stride);

  void addOdometry(ceres::Problem& problem);
  void addTiltPrior(ceres::Problem& problem);

  /// Variance-component check of the SLAM's noise: the GNSS's inliers should stay from the
  /// fused trajectory within their own noise (the reported std-dev, or for fixes without one
  /// the roughness bound of the GNSS track, which does not depend on the SLAM). Where they stay
  /// further by a factor beyond kStiffSlam, the SLAM was held stiffer than it deserves (its
  /// errors were taken for GNSS noise and good fixes rejected): its noise is raised by that
  /// factor and the fusion solved again from the start.
  void adaptSlamNoise();

  /// Robust spread of the inliers' horizontal residuals in units of their own noise (1 when
  /// the fused trajectory leaves them as much as their noise says).
  double stiffness() const;

  /// The clock offset the speed profiles show, from the fixes that take part (a receiver's own
  /// large std-dev, as in an outage, would only add noise).
  /// The fixes are restamped by it (shift_): every fix's factor is made at its instant on the
  /// SLAM's clock, and the fusion's own offset (dt_) is what remains.
  void estimateClock();
  /// The GNSS of the fixes taking part, in their order.
  std::vector<GnssPoint> fixesTakingPart() const;
  /// The heading profile's offset with the antenna at `antenna` (body frame), searched from
  /// `start`; not observable without max_time_offset or beyond it.
  ClockOffsetEstimate headingProfile(const std::vector<GnssPoint>& fixes, const Vec3& antenna,
                                     double start) const;

  /// The last solve, to the fine tolerance: the heading of the fused trajectory, which the
  /// points beside it carry into the map, converges last. The problem is kept for what is
  /// measured at the solution.
  void polish();
  /// Code-grade fixes the graph rejected that are apart from it in height alone
  /// (apartInHeightAlone()) take part with their horizontal part alone.
  void leaveOutHeights();

  /// The clock to the millisecond: the factor moves a fix by velocity x dt_ (first order, off
  /// by acceleration x dt_^2 / 2), so while the remainder is more than kRestampTolerance the
  /// fixes are restamped by it, their factors, keyframes and jitter made again at their new
  /// instants, and the full problem solved again from where it stands.
  void restamp();

  /// The fixes restamped at `shift` (their factors, keyframes and jitter made again at their new
  /// instants, dt_ 0) and the full problem solved again from where it stands.
  void solveRestampedAt(double shift);

  /// Two measures of the clock: the speed profiles, which no shape error of the SLAM moves, and
  /// the fit of positions, which can take one for an offset. Where they disagree, the offset is
  /// held where heldClockOffset() says and the full problem solved again at it.
  void holdClockWhereTheSpeedsDisagree();

  /// The fit's own 1-sigma of the offset, where the profiles knew it loosely (ClockEstimate::
  /// loose): from the curvature of the cost with the offset moved kOffsetProbe either way and
  /// everything else solved again (a profile likelihood), kClockSystematic added; at most the
  /// profiles' sigma.
  double fittedOffsetSigma();

  /// The 1-sigma of the antenna's offset `along` a direction of the body (unit, x y) at the
  /// solution, everything else (the clock offset among it) free: Ceres's covariance of the
  /// block, the fixes weighed with their own std-devs.
  double antennaSigma(const Eigen::Vector2d& along);

  /// Where no lever arm was given, the drive turns and its speed profile shows the clock: the
  /// antenna's horizontal offset from the poses' origin, fitted with the rest from the solution
  /// at 0. Kept where it is beyond kNotableAntenna and told from 0 by kLeverTold sigmas (along
  /// the track a clock offset moves the fixes as it does: only changes of speed tell them apart),
  /// and the stages solved again from the start with it; else the solution at 0 stands.
  void fitAntenna();
  /// The heading profile again with the antenna's offset fitAntenna() estimated, and the
  /// profiles' clock combined anew (the offset decided stays; its sigma is theirs).
  void reviewHeadingProfile();

  /// The stages again from the rigid start and the std-devs' first guesses (the SLAM's noise
  /// and the antenna's offset as they stand).
  void solveFromStart();

  /// An offset the profiles knew loosely (ClockEstimate::loose): the fit of positions decides it
  /// (observable), but on a straight (kLeastTurn) or where a run before found the fit's offset
  /// not told from 0 or a SLAM's own lag (loose_fit_); the reason then says which.
  void decideLooseClock();

  /// Squared normalised residual of a fix at the current estimate.
  double squaredResidual(const Fix& f) const;

  /// Graduated non-convexity on the GNSS weights: every fix is first weighted as if its
  /// std-dev were at least a `floor` of metres, at which the SLAM's shape holds the trajectory
  /// and a slowly varying GNSS bias cannot bend it; the floor shrinks by 3 stage by stage down
  /// to the fixes' own std-devs, while the redescending loss (scale outlier_threshold, in units
  /// of the current std-dev) drops the fixes that stay far off. The std-devs of fixes without
  /// one are then estimated from the inliers and the last stages solved again.
  void solveStages();

  /// Solves from the current estimate, every fix weighted as if its std-dev were at least
  /// `floor`; returns the cost reached. The stages stop at a coarse tolerance (kStageTolerance):
  /// their result is the next stage's start, and only the last solve (polish) runs to
  /// kFinalTolerance.
  double solveAt(ceres::Problem& problem, double floor, int iterations,
                 double tolerance = kStageTolerance);

  /// Moves the clock offset (shift_ + dt_) back within max_time_offset where a solve took it
  /// beyond; true if it did.
  bool clampOffset();

  /// Sets the std-dev of the fixes without one to the robust spread of their inliers'
  /// residuals; true when it changed by more than a fifth (solve again). (Taken from all
  /// fixes, a fit-independent way or by maximum likelihood, it was tried and lost:
  /// doc/ACCURACY.md.)
  bool estimateUnknownStd();

  /// Reported std-devs re-estimated from the drive, per class (kClassBounds): the white noise
  /// of the class's fixes less the SLAM at the rigid start (third divided differences of four
  /// consecutive fixes of the class at their stamps, where the SLAM takes the motion out; no fit
  /// is involved, whose residuals would shrink with the std-dev it assumes) in units of the
  /// std-dev they report, its Gaussian core (robustSigma: multipath and outliers have no part
  /// in it). That is the factor the class's std-devs are scaled by (0.5 to 100), where it is
  /// beyond kClassTolerance.
  void estimateClassScales();

  /// The class of a fix's reported std-dev; -1 for a fix without one.
  int fixClass(const Fix& f) const { return f.known_std ? classOf(gnss_[f.input].std_dev) : -1; }

  /// Residual of a fix in metres (ENU).
  Vec3 residualOf(const Fix& f) const;

  double weightOf(const Fix& f) const;

  Eigen::Isometry3d keyframePose(const Keyframe& k) const;

  void collect();

  /// Every pose: its keyframe's fused pose, moved by the SLAM's motion since (scale applied).
  void fusedPoses();

  const Trajectory& poses_;
  const std::vector<GnssPoint>& gnss_;
  const FusionOptions options_;
  const CancelToken& cancel_;
  std::optional<Eigen::Vector2d> loose_fit_;  ///< see the constructor
  Noise noise_;
  std::vector<Keyframe> keyframes_;
  std::vector<Fix> fixes_;
  Vec3 origin_ = Vec3::Zero();  ///< ENU of the graph's origin
  /// The rigid start: T_enu_map, in the graph's frame.
  Eigen::Isometry3d start_ = Eigen::Isometry3d::Identity();
  double shift_ = 0.0;  ///< s added to every fix's stamp before its factor is made
  double dt_ = 0.0;     ///< s, the fusion's estimate on top of shift_
  /// m, the antenna's offset from the poses' origin along the body's forward and left axes,
  /// estimated where no lever arm was given (estimate_lever_).
  double lever_[2] = {0.0, 0.0};
  bool estimate_lever_ = false;
  double offset_sigma_ = kInf;  ///< s, 1-sigma of shift_ + dt_
  ClockOffsetEstimate clock_;
  double unknown_h_ = kUnknownStdStart, unknown_v_ = kUnknownStdStart;
  double roughness_ = 0.0;
  double start_unknown_h_ = kUnknownStdStart, start_unknown_v_ = kUnknownStdStart;
  double class_scale_[kClasses] = {1.0, 1.0, 1.0};  ///< factors on the reported std-devs

  std::shared_ptr<GemanMcClure> loss_;            ///< shared by the copies, which only read it
  std::shared_ptr<GemanMcClure> loss_imprecise_;  ///< for fixes of kPreciseStd or worse
  int solver_threads_;                            ///< Ceres's threads per solve
  QuaternionBlock quaternion_;
  FusionResult out_;
};

}  // namespace fusion_graph
}  // namespace flexcloud
