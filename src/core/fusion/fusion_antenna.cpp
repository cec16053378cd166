// The antenna's offset from the poses' origin, where no lever arm was given: estimated with
// the rest, kept only where the drive tells it from a clock offset.
#include <algorithm>
#include <cmath>

#include "fusion_graph.h"

namespace flexcloud {
namespace fusion_graph {
namespace {

/// The body's mean direction of travel in its own horizontal axes (x, y), unit; x where the
/// poses barely move.
Eigen::Vector2d travelInBody(const Trajectory& poses) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (std::size_t i = 1; i < poses.size(); ++i) {
    const Vec3 step =
        poses[i].orientation.conjugate() * (poses[i].position - poses[i - 1].position);
    if (step.head<2>().norm() > 0.0) sum += step.head<2>().normalized();
  }
  return sum.norm() > 0.0 ? Eigen::Vector2d(sum.normalized()) : Eigen::Vector2d::UnitX();
}

/// The fixes' std-devs as the last solve left them, to be put back after a solve beside it.
std::vector<Vec3> sigmasOf(const std::vector<Fix>& fixes) {
  std::vector<Vec3> out;
  out.reserve(fixes.size());
  for (const auto& f : fixes) out.push_back(f.sigma);
  return out;
}

void putBack(const std::vector<Vec3>& sigmas, std::vector<Fix>& fixes) {
  for (std::size_t i = 0; i < fixes.size(); ++i) fixes[i].sigma = sigmas[i];
}

}  // namespace

double Fusion::antennaSigma(const Eigen::Vector2d& along) {
  // Weighed with their own std-devs for the measure, as the stage left them after it.
  const std::vector<Vec3> stage = sigmasOf(fixes_);
  for (auto& f : fixes_) f.sigma = f.own;
  const auto problem = makeProblem(1);
  ceres::Covariance::Options o;
  o.num_threads = solver_threads_;
  ceres::Covariance covariance(o);
  const std::vector<std::pair<const double*, const double*>> blocks = {{lever_, lever_}};
  // Rank-deficient where some block has nothing to hold it: the offset is not told then.
  const bool told = covariance.Compute(blocks, problem.get());
  Eigen::Matrix2d c = Eigen::Matrix2d::Constant(kInf);
  if (told) covariance.GetCovarianceBlock(lever_, lever_, c.data());
  putBack(stage, fixes_);
  return told ? std::sqrt(std::max(0.0, along.dot(c * along))) : kInf;
}

void Fusion::fitAntenna() {
  // On a straight an antenna's offset moves every fix as a shift of the whole track does; along
  // the track it moves them as a clock offset does, which only a varying speed tells apart:
  // where the speed profile cannot show the clock, a SLAM's shape error in the turns reads as
  // an offset (open_rtk_drifting, a SLAM whose rotation wanders: 0.56-1.14 m, at 3.4-7.3 sigma).
  // Where it can, the clock need not be off: stamps put right by gnss_time_offset leave the
  // antenna as estimable (loop_offset_lever: 1.17 m along, 0.43 across, with the clock or
  // without).
  if (!options_.lever_arm.isZero() || !out_.clock.speed.observable ||
      crossSpeedSpread(poses_) < kLeastTurn)
    return;
  const std::vector<Keyframe> held = keyframes_;
  const double dt = dt_;
  const std::vector<Vec3> sigmas = sigmasOf(fixes_);  // the solve below weighs them by their own
  estimate_lever_ = true;
  {
    const auto full = makeProblem(1);
    solveAt(*full, 0.0, 10);
  }
  const Eigen::Vector2d lever(lever_[0], lever_[1]);
  if (lever.norm() > kNotableAntenna) {
    out_.antenna_offset_sigma = antennaSigma(travelInBody(poses_));
    if (lever.norm() > kLeverTold * out_.antenna_offset_sigma) {
      // Which fixes are outliers was decided without it: decided again, from the start.
      solveFromStart();
      return;
    }
  }
  estimate_lever_ = false;
  lever_[0] = lever_[1] = 0.0;
  out_.antenna_offset_sigma = 0.0;
  keyframes_ = held;
  dt_ = dt;
  putBack(sigmas, fixes_);
}

}  // namespace fusion_graph
}  // namespace flexcloud
