// The fusion's Ceres problem and its solves: the graph, the stages of graduated non-convexity.
#include <algorithm>
#include <cmath>

#include "flexcloud/metrics.h"
#include "fusion_graph.h"

namespace flexcloud {
namespace fusion_graph {

std::unique_ptr<ceres::Problem> Fusion::makeProblem(std::size_t stride) {
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  keepBlockShapes(options);
  auto problem = std::make_unique<ceres::Problem>(options);
  for (auto& k : keyframes_) problem->AddParameterBlock(k.q, 4, &quaternion_);
  addOdometry(*problem);
  Keyframe& k0 = keyframes_.front();
  problem->AddResidualBlock(
      new ceres::AutoDiffCostFunction<ZeroPrior, 3, 3>(new ZeroPrior{3, 1e-3}), nullptr, k0.w);
  problem->AddResidualBlock(
      new ceres::AutoDiffCostFunction<ZeroPrior, 1, 1>(new ZeroPrior{1, 0.05}), nullptr, &k0.s);
  addTiltPrior(*problem);
  problem->AddParameterBlock(lever_, 2);
  if (estimate_lever_) {
    problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<ZeroPrior, 2, 2>(new ZeroPrior{2, kLeverSigma}), nullptr,
        lever_);
  } else {
    problem->SetParameterBlockConstant(lever_);
  }
  problem->AddParameterBlock(&dt_, 1);
  if (out_.time_offset_held) {
    problem->SetParameterBlockConstant(&dt_);
  } else if (clock_.observable) {
    // A clock offset moves every fix along the track, and in a fit of positions a SLAM whose
    // heading wanders more than its noise says can pass for one (0.08 s, 1 m along the
    // track, on a drive without any). The speed profiles, which no rotation changes, set
    // it; the fixes refine it within the profiles' uncertainty.
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<OffsetPrior, 1, 1>(new OffsetPrior{
                                  clock_.offset - shift_, std::max(kMinOffsetSigma, clock_.sigma)}),
                              nullptr, &dt_);
    // No bounds at max_time_offset here: with a bound on any block Ceres searches along
    // every step, a tenth of the fusion's time on a2rl; solveAt holds the offset instead.
  } else {
    problem->SetParameterBlockConstant(&dt_);  // none asked for, or the speed too even
  }
  for (std::size_t j = 0; j < fixes_.size(); j += stride) {
    Fix& f = fixes_[j];
    Keyframe& k = keyframes_[f.keyframe];
    f.imprecise = (f.known_std ? ownSigma(gnss_[f.input].std_dev, 0.0, 0.0).x()
                               : out_.unknown_white.x()) >= kPreciseStd;
    ceres::LossFunction* loss = f.imprecise ? loss_imprecise_.get() : loss_.get();
    if (f.level_only) {
      problem->AddResidualBlock(new GnssLevelCost(f.factor), loss, k.q, k.p, &k.s, &dt_, lever_);
    } else {
      problem->AddResidualBlock(new GnssCost(f.factor), loss, k.q, k.p, &k.s, &dt_, lever_);
    }
  }
  return problem;
}

void Fusion::addTiltPrior(ceres::Problem& problem) {
  // The tilt a drive's GNSS cannot see stays the start's: on a straight road the roll about it
  // moves no fix, and the graph rolled KITTI 04 (400 m straight) by 11 degrees to fit the
  // SLAM's height drift into the road's slight curve. Each keyframe's up is held to the
  // start's with kTiltSigma times the square root of their number: together, their mean
  // within kTiltSigma; alone, each free to follow the tilt drift the fixes show. At 1 degree
  // a2rl's held-out MAX grew by 5 cm (its start is fitted before its clock is known).
  const double sigma = kTiltSigma * std::sqrt(static_cast<double>(keyframes_.size()));
  for (auto& k : keyframes_) {
    const Eigen::Matrix3d start = (start_ * k.slam).linear();
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<TiltPrior, 2, 4>(new TiltPrior{
                                 start.transpose() * Eigen::Vector3d::UnitZ(), sigma}),
                             nullptr, k.q);
  }
}

void Fusion::addOdometry(ceres::Problem& problem) {
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

void Fusion::polish() {
  const auto full = makeProblem(1);
  solveAt(*full, 0.0, kPolishIterations, kFinalTolerance);
}

double Fusion::squaredResidual(const Fix& f) const {
  const Keyframe& k = keyframes_[f.keyframe];
  double r[3];
  f.factor(k.q, k.p, &k.s, &dt_, lever_, r);
  return r[0] * r[0] + r[1] * r[1] + (f.level_only ? 0.0 : r[2] * r[2]);
}

void Fusion::leaveOutHeights() {
  for (Fix& f : fixes_) {
    if (!f.imprecise || weightOf(f) >= kRejectWeight) continue;
    f.level_only = apartInHeightAlone(residualOf(f), f.own);
  }
}

void Fusion::solveStages() {
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

double Fusion::solveAt(ceres::Problem& problem, double floor, int iterations, double tolerance) {
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
  ++out_.stages;
  out_.solves += solves;
  return summary.final_cost;
}

bool Fusion::clampOffset() {
  if (!clock_.observable) return false;
  const double bound = options_.max_time_offset;
  const double offset = shift_ + dt_;
  // Compared as the sum: (shift_ + dt_) - shift_ need not give dt_ back to the last bit, and
  // taken for a move it redid every solve.
  if (std::abs(offset) <= bound) return false;
  dt_ = std::clamp(offset, -bound, bound) - shift_;
  return true;
}

Vec3 Fusion::residualOf(const Fix& f) const {
  const Keyframe& k = keyframes_[f.keyframe];
  double r[3];
  f.factor(k.q, k.p, &k.s, &dt_, lever_, r);
  return Vec3(r[0], r[1], r[2]).cwiseProduct(f.sigma);
}

double Fusion::weightOf(const Fix& f) const {
  return (f.imprecise ? *loss_imprecise_ : *loss_).weight(squaredResidual(f));
}

}  // namespace fusion_graph
}  // namespace flexcloud
