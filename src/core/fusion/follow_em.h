#pragma once
// The EM of the refinement by precise fixes (precise_follow.h): the correction smoothed per
// axis (a random walk over the path, Rauch-Tung-Striebel), its intensity q learned by maximum
// likelihood, each fix's chance of being an outlier and each step's of being a bend or a jump
// of the SLAM. Private to the core.

#include <array>
#include <vector>

#include "follow_series.h"

namespace flexcloud {
namespace follow {

/// One axis smoothed: means, variances, the covariance of each value with the next, and the
/// weighted log-likelihood of the innovations (the first left out).
struct Smoothed {
  std::vector<double> m, P, C;
  double loglik = 0.0;
};

/// Rauch-Tung-Striebel smoothing of axis `axis` of s.r: the random walk with per-step
/// variance Q (Q[0] unused) and first variance P0, each value measured with variance s.var / w
/// (not at all where w is near 0).
Smoothed smoothAxis(const Series& s, int axis, const std::vector<double>& Q,
                    const std::vector<double>& w, double P0);

class Refinement {
 public:
  Refinement(const Series& s, const FollowOptions& o);

  /// `start` is the keyframe graph's weight of each fix, `jumps` the steps the residuals alone
  /// show a jump at (detectJumps). Runs of fixes the graph rejected that lie too far for a
  /// short-term error of the SLAM (holdFarRuns) stay out where the GNSS shows a fault at their
  /// edge, and are followed (kept at full say) where it does not; every other fix starts with
  /// full say, whatever the graph called it. Round 0 smooths at q = start_q; every later round
  /// learns q by maximum likelihood with the fixes weighted as the round before judged them.
  void run(const std::vector<double>& jumps, const std::vector<double>& start);

  const std::vector<double>& weights() const { return w_; }
  const std::vector<double>& jumps() const { return jump_; }
  const std::vector<bool>& locked() const { return locked_; }
  /// Per fix: whether it lies in a run followed though far from the SLAM's shape.
  const std::vector<bool>& followed() const { return followed_; }
  double q(int group) const { return q_[group]; }
  double excess() const { return excess_; }
  Vec3 correction(std::size_t j) const { return Vec3(sm_[0].m[j], sm_[1].m[j], sm_[2].m[j]); }

 private:
  double qOf(int axis) const { return q_[axis < 2 ? 0 : 1]; }
  std::vector<double> steps(double q) const;
  double loglik(std::initializer_list<int> axes, double q) const;
  double learnQ(std::initializer_list<int> axes) const;
  void smoothAll();
  double slamExcess() const;
  /// Sets locked_ and followed_ (see run()).
  void holdFarRuns(const std::vector<double>& start);
  /// Whether the GNSS shows a fault at the edge between fix `inside` (of a rejected run) and
  /// its neighbour `outside`: a step near it, a return after a gap across it, a change of claim
  /// near it.
  bool faultAtEdge(std::size_t inside, std::size_t outside) const;
  /// Whether fixes a..b each claim 5 cm or better (without a std-dev: the noise measured).
  bool claimsPrecision(std::size_t a, std::size_t b) const;
  /// Whether fixes a..b were drawn (through an outage), not measured: those without a std-dev
  /// show less than kDrawnShare of `unclaimed_noise`, the median of the drive's such fixes.
  bool drawn(std::size_t a, std::size_t b, double unclaimed_noise) const;
  bool stepNear(double centre) const;
  bool returnAfterGap(std::size_t lo, std::size_t hi) const;
  bool claimChangesNear(double centre) const;
  void updateWeights();
  void updateSteps();

  const Series& s_;
  const FollowOptions& o_;
  std::vector<double> w_, jump_, bend_, candidates_;
  std::vector<bool> locked_, followed_;
  double q_[2] = {1e-9, 1e-9};
  double excess_ = 0.0;
  std::array<Smoothed, 3> sm_;
};

}  // namespace follow
}  // namespace flexcloud
