// The fusion's clock offset: from the speed and heading profiles, refined by the fit of
// positions and restamped to the millisecond.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "fusion_graph.h"

namespace flexcloud {
namespace fusion_graph {

double crossSpeedSpread(const Trajectory& poses) {
  std::vector<Eigen::Vector2d> v;
  for (std::size_t i = 1; i < poses.size(); ++i) {
    const double dt = poses[i].stamp - poses[i - 1].stamp;
    if (dt > 0.0) v.push_back((poses[i].position - poses[i - 1].position).head<2>() / dt);
  }
  if (v.size() < 2) return 0.0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& x : v) mean += x;
  mean /= static_cast<double>(v.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& x : v) cov += (x - mean) * (x - mean).transpose();
  cov /= static_cast<double>(v.size());
  return std::sqrt(
      std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues()(0)));
}

std::vector<GnssPoint> Fusion::fixesTakingPart() const {
  std::vector<GnssPoint> out;
  for (const auto& f : fixes_) out.push_back(gnss_[f.input]);
  return out;
}

ClockOffsetEstimate Fusion::headingProfile(const std::vector<GnssPoint>& fixes, const Vec3& antenna,
                                           double start) const {
  ClockOffsetEstimate heading;
  if (!(options_.max_time_offset > 0.0)) return heading;
  heading = estimateHeadingOffset(poses_, antenna, fixes, start);
  if (std::abs(heading.offset) > options_.max_time_offset) heading.observable = false;
  return heading;
}

void Fusion::estimateClock() {
  const std::vector<GnssPoint> taking_part = fixesTakingPart();
  const ClockOffsetEstimate speed =
      estimateClockOffset(poses_, taking_part, options_.max_time_offset);
  const ClockOffsetEstimate heading =
      headingProfile(taking_part, options_.lever_arm, speed.observable ? speed.offset : 0.0);
  out_.clock = combineClock(speed, heading);
  if (out_.clock.loose) decideLooseClock();
  // The fusion refines the offset only where the profiles tell it from 0, within their sigma,
  // or where they know it loosely: from the stamps as given, within that sigma.
  clock_ = speed;
  clock_.observable = out_.clock.observable;
  clock_.offset = out_.clock.loose ? 0.0 : out_.clock.offset;
  clock_.sigma = out_.clock.sigma;
  shift_ = clock_.observable ? clock_.offset : 0.0;
  dt_ = 0.0;
}

void Fusion::reviewHeadingProfile() {
  if (!estimate_lever_ || !out_.clock.speed.observable) return;
  // The course of the antenna, not of the poses' origin: an antenna L ahead turns its course by
  // the turn rate times L / v, as a clock L / v late does (MulRan, 1.6 m ahead at 7 m/s: the
  // heading profile 190-300 ms off the truth without it, -10 to +20 ms with it). The antenna is
  // estimated only where no lever arm was given.
  const ClockOffsetEstimate heading =
      headingProfile(fixesTakingPart(), Vec3(lever_[0], lever_[1], 0.0), out_.clock.speed.offset);
  const ClockEstimate reviewed = combineClock(out_.clock.speed, heading);
  // The profiles' word is renewed, with it the offset the fit of positions is drawn to (the
  // fit, far tighter, moves by a few tenths of a millisecond: KAIST_03 -12.3 -> -11.9 ms off
  // the truth); how the offset was decided stands.
  if (reviewed.observable != out_.clock.observable || reviewed.loose != out_.clock.loose) return;
  out_.clock = reviewed;
  if (!reviewed.loose) clock_.offset = reviewed.offset;
  clock_.sigma = reviewed.sigma;
}

void Fusion::restamp() {
  for (int round = 0; round < kRestampRounds; ++round) {
    if (!clock_.observable || !(std::abs(dt_) > kRestampTolerance)) break;
    solveRestampedAt(shift_ + dt_);
  }
}

void Fusion::solveRestampedAt(double shift) {
  shift_ = shift;
  dt_ = 0.0;
  selectFixes();
  prepareFixes(unknown_h_, unknown_v_);
  const auto full = makeProblem(1);
  solveAt(*full, 0.0, 10);
}

void Fusion::holdClockWhereTheSpeedsDisagree() {
  out_.time_offset_from_positions = shift_ + dt_;
  ClockOffsetEstimate speed = out_.clock.speed;
  speed.sigma = out_.clock.sigma;
  const std::optional<double> held = heldClockOffset(shift_ + dt_, speed);
  if (!held) return;
  out_.time_offset_held = true;
  solveRestampedAt(*held);
}

double Fusion::fittedOffsetSigma() {
  const std::vector<Keyframe> best = keyframes_;
  const double at = dt_;
  const auto problem = makeProblem(1);
  problem->SetParameterBlockConstant(&dt_);
  // keyframes_ keeps its storage: the problem's blocks point into it.
  const auto costAt = [&](double dt) {
    keyframes_ = best;
    dt_ = dt;
    return solveAt(*problem, 0.0, kPolishIterations, kFinalTolerance);
  };
  const double c0 = costAt(at);
  const double curvature = costAt(at + kOffsetProbe) + costAt(at - kOffsetProbe) - 2.0 * c0;
  keyframes_ = best;
  dt_ = at;
  if (!(curvature > 0.0)) return clock_.sigma;
  return std::min(clock_.sigma, std::hypot(kOffsetProbe / std::sqrt(curvature), kClockSystematic));
}

void Fusion::decideLooseClock() {
  ClockEstimate& c = out_.clock;
  if (loose_fit_) {
    char told[96];
    std::snprintf(told, sizeof(told), "%.1f +- %.1f ms", 1e3 * loose_fit_->x(),
                  1e3 * loose_fit_->y());
    c.reason += std::string(", and the fit of positions puts it at ") + told +
                ", no more than its noise or a SLAM's own lag can show";
  } else if (crossSpeedSpread(poses_) < kLeastTurn) {
    c.reason += ", and the drive turns too little for the fit of positions to tell it";
  } else {
    c.observable = true;
    c.reason.clear();
    return;
  }
  c.loose = false;
}

}  // namespace fusion_graph
}  // namespace flexcloud
