#include "follow_em.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "flexcloud/metrics.h"

namespace flexcloud {
namespace follow {
namespace {

constexpr double kTwoPi = 6.283185307179586;
constexpr double kLogQLow = -9.0, kLogQHigh = 0.0;  // log10 of q's range, m^2 per m
constexpr int kGoldenSteps = 20;
constexpr double kMinWeight = 1e-6;
constexpr double kFarSigmas = 6.0;
// A fault of the GNSS at the edge of a rejected run: within this many seconds of it, a step
// of the residual beyond kStepSigmas of the two fixes' joint sigma, or a gap this long after
// which the residual moved further than that and kDriftRate (m/s: faster than the SLAM failures
// seen, which moved the residual by at most 0.7 m in a second and far less over longer spans);
// or the claimed std-dev changing by more than kClaimChange.
constexpr double kEdgeSeconds = 1.0;
constexpr double kStepSigmas = 10.0;
// Of the path between two fixes, the share a SLAM's own error may move the residual by: a race
// car's SLAM (a2rl, 70 m/s, fixes 0.6 s apart) stepped back by 0.9 m over 42 m where it
// recovered from a failure the GNSS showed.
constexpr double kStepPath = 0.02;
constexpr double kDriftRate = 0.5;
constexpr double kClaimChange = 1.5;
constexpr double kClaimSeconds = 5.0;
constexpr std::size_t kLeastRun = 10;   // fixes of a run followed without a fault at its edges
constexpr double kPreciseClaim = 0.05;  // m: a fix claiming this or better claims precision
// A run of fixes without a std-dev whose positions show less than this share of the white noise
// of the drive's such fixes was drawn, not measured: on a2rl the curve drawn through its outage
// shows 0.24 of it, its fixes 0.4-0.7 m from the SLAM at 38-55 s 1.46.
constexpr double kDrawnShare = 0.5;

}  // namespace

Smoothed smoothAxis(const Series& s, int axis, const std::vector<double>& Q,
                    const std::vector<double>& w, double P0) {
  const std::size_t n = s.size();
  std::vector<double> mp(n), Pp(n), mf(n), Pf(n);
  Smoothed out;
  double m = 0.0, P = P0;
  for (std::size_t j = 0; j < n; ++j) {
    if (j > 0) P += Q[j];
    mp[j] = m, Pp[j] = P;
    if (w[j] > kMinWeight) {
      const double S = P + s.var[j](axis) / w[j];
      const double nu = s.r[j](axis) - m;
      if (j > 0) out.loglik += w[j] * -0.5 * (nu * nu / S + std::log(kTwoPi * S));
      const double K = P / S;
      m += K * nu;
      P *= 1.0 - K;
    }
    mf[j] = m, Pf[j] = P;
  }
  out.m = mf, out.P = Pf, out.C.assign(n, 0.0);
  for (std::size_t j = n - 1; j-- > 0;) {
    const double J = Pp[j + 1] > 0.0 ? Pf[j] / Pp[j + 1] : 0.0;
    out.m[j] = mf[j] + J * (out.m[j + 1] - mp[j + 1]);
    out.P[j] = Pf[j] + J * J * (out.P[j + 1] - Pp[j + 1]);
    out.C[j] = J * out.P[j + 1];
  }
  return out;
}

Refinement::Refinement(const Series& s, const FollowOptions& o)
    : s_(s), o_(o), w_(s.size(), 1.0), jump_(s.size(), 0.0), bend_(s.size(), 0.0) {}

void Refinement::run(const std::vector<double>& jumps, const std::vector<double>& start) {
  jump_ = candidates_ = jumps;
  excess_ = slamExcess();
  holdFarRuns(start);
  for (std::size_t j = 0; j < w_.size(); ++j) w_[j] = locked_[j] ? 0.0 : 1.0;
  q_[0] = q_[1] = o_.start_q;
  for (int round = 0; round < o_.rounds; ++round) {
    if (round > 0) {
      q_[0] = learnQ({0, 1});
      q_[1] = learnQ({2});
    }
    smoothAll();
    updateWeights();
    updateSteps();
  }
  smoothAll();
}

std::vector<double> Refinement::steps(double q) const {
  const double b2 = o_.bend_ratio * o_.bend_ratio, j2 = o_.jump_sigma * o_.jump_sigma;
  std::vector<double> Q(s_.size());
  for (std::size_t j = 0; j < Q.size(); ++j) {
    const double core = q * s_.step(j);
    Q[j] = (1.0 - jump_[j] - bend_[j]) * core + bend_[j] * b2 * core + jump_[j] * j2;
  }
  return Q;
}

double Refinement::loglik(std::initializer_list<int> axes, double q) const {
  const std::vector<double> Q = steps(q);
  double ll = 0.0;
  for (int a : axes) ll += smoothAxis(s_, a, Q, w_, q * o_.start_metres).loglik;
  return ll;
}

double Refinement::learnQ(std::initializer_list<int> axes) const {
  // Golden-section search of log10 q for the largest likelihood of the innovations.
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = kLogQLow, b = kLogQHigh;
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = loglik(axes, std::pow(10.0, c)), fd = loglik(axes, std::pow(10.0, d));
  for (int i = 0; i < kGoldenSteps; ++i) {
    if (fc > fd) {
      b = d, d = c, fd = fc;
      c = b - g * (b - a);
      fc = loglik(axes, std::pow(10.0, c));
    } else {
      a = c, c = d, fc = fd;
      d = a + g * (b - a);
      fd = loglik(axes, std::pow(10.0, d));
    }
  }
  return std::pow(10.0, 0.5 * (a + b));
}

void Refinement::smoothAll() {
  for (int a = 0; a < 3; ++a) {
    sm_[static_cast<std::size_t>(a)] =
        smoothAxis(s_, a, steps(qOf(a)), w_, qOf(a) * o_.start_metres);
  }
}

double Refinement::slamExcess() const {
  // The SLAM's short-term error beyond the fixes' own noise: the robust spread of the
  // residuals' horizontal components, less the fixes' median own variance. A few centimetres
  // for a real LiDAR odometry, none for a SLAM that errs only slowly.
  std::vector<double> c, own;
  for (std::size_t j = 0; j < s_.size(); ++j) {
    c.push_back(s_.r[j].x()), c.push_back(s_.r[j].y());
    own.push_back(s_.var[j].x());
  }
  const double spread = madSigma(std::move(c));
  return std::sqrt(std::max(0.0, spread * spread - median(std::move(own))));
}

bool Refinement::stepNear(double centre) const {
  // A step of the residual (fix less the graph's trajectory) between consecutive fixes within a
  // second of the edge that neither fix's claim nor the SLAM's short-term motion can make. A
  // SLAM that fails bends away gradually: on the MulRan drives, the runs it made the graph
  // reject step by at most 0.20 m from fix to fix near their edges (against 10 of these 2 cm
  // fixes' joint sigmas, 0.28 m).
  for (std::size_t j = 1; j < s_.size(); ++j) {
    if (std::abs(s_.t[j] - centre) > kEdgeSeconds || s_.t[j] - s_.t[j - 1] > kEdgeSeconds) {
      continue;
    }
    const double sigma =
        std::sqrt(s_.var[j].x() + s_.var[j - 1].x()) + 2.0 * excess_ + kStepPath * s_.step(j);
    if ((s_.r[j] - s_.r[j - 1]).head<2>().norm() > kStepSigmas * sigma) return true;
  }
  return false;
}

bool Refinement::returnAfterGap(std::size_t lo, std::size_t hi) const {
  // Further off after a gap than the SLAM's drift can carry the residual over it.
  const double gap = s_.t[hi] - s_.t[lo];
  if (!(gap > kEdgeSeconds)) return false;
  const double sigma = std::sqrt(s_.var[hi].x() + s_.var[lo].x()) + 2.0 * excess_;
  return (s_.r[hi] - s_.r[lo]).head<2>().norm() > kStepSigmas * sigma + kDriftRate * gap;
}

bool Refinement::claimChangesNear(double centre) const {
  // The receiver's claim changes within kClaimSeconds of the edge (its status: fixed against
  // float): a departure that grows smoothly is rejected only once it passes the fixes' noise, a
  // second or so after it set in. A fix of worse claim between two of the series is such a
  // change too. (One rougher than it claims is not: on MulRan, where every fix is honest, the
  // SLAM's failure makes the residuals rough at some edges.)
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  for (std::size_t j = 0; j < s_.size(); ++j) {
    if (std::abs(s_.t[j] - centre) > kClaimSeconds) continue;
    if (s_.doubt[j]) return true;
    if (!std::isfinite(s_.claim[j])) continue;
    lo = std::min(lo, s_.claim[j]);
    hi = std::max(hi, s_.claim[j]);
  }
  return hi > kClaimChange * lo;
}

bool Refinement::faultAtEdge(std::size_t inside, std::size_t outside) const {
  const double centre = s_.t[std::max(inside, outside)];
  return stepNear(centre) || returnAfterGap(std::min(inside, outside), std::max(inside, outside)) ||
         claimChangesNear(centre);
}

void Refinement::holdFarRuns(const std::vector<double>& start) {
  // A run of fixes the graph rejected whose median horizontal distance from its trajectory
  // lies beyond run_excess times the SLAM's excess (and kFarSigmas of the fixes' own
  // std-devs: the graph rejects from 4.4 of them on, the tail of their noise) is further off
  // than a SLAM's short-term error; it stays out only where the GNSS itself shows a fault at
  // either edge (faultAtEdge): fixes that claim precision, agree with each other and run on
  // without a step are followed however far the SLAM lies from them. On every real drive seen,
  // such a stretch was the SLAM failing (MulRan Riverside_02: 70 s, 8.7 m); the outlier
  // component takes no part there, since the correction must bend faster than the SLAM's
  // usual error for them (a2rl: 17 m over 28 s, the fixes held out of it within 0.8 m).
  locked_.assign(start.size(), false);
  followed_.assign(start.size(), false);
  std::vector<double> noise;  // of the fixes that came without a std-dev
  for (std::size_t j = 0; j < start.size(); ++j) {
    if (!std::isfinite(s_.claim[j]) && std::isfinite(s_.noise[j])) noise.push_back(s_.noise[j]);
  }
  const double unclaimed_noise =
      noise.empty() ? std::numeric_limits<double>::quiet_NaN() : median(noise);
  for (std::size_t a = 0; a < start.size();) {
    if (start[a] >= 0.5) {
      ++a;
      continue;
    }
    std::size_t b = a;
    while (b + 1 < start.size() && start[b + 1] < 0.5) ++b;
    std::vector<double> d, own;
    for (std::size_t k = a; k <= b; ++k) {
      d.push_back(s_.r[k].head<2>().norm());
      own.push_back(std::sqrt(s_.var[k].x()));
    }
    const bool far = median(d) > o_.run_excess * excess_ + kFarSigmas * median(own);
    // A few fixes are no run: outliers, or the ends of an episode whose middle scattered.
    const bool run =
        claimsPrecision(a, b) && b - a + 1 >= kLeastRun && s_.t[b] - s_.t[a] >= kEdgeSeconds;
    const bool fault = !run || drawn(a, b, unclaimed_noise) || (a > 0 && faultAtEdge(a, a - 1)) ||
                       (b + 1 < start.size() && faultAtEdge(b, b + 1));
    if (far) {
      std::fill((fault ? locked_ : followed_).begin() + static_cast<std::ptrdiff_t>(a),
                (fault ? locked_ : followed_).begin() + static_cast<std::ptrdiff_t>(b) + 1, true);
    }
    a = b + 1;
  }
}

bool Refinement::claimsPrecision(std::size_t a, std::size_t b) const {
  // A fix that came without a std-dev counts with the white noise measured from such fixes
  // (their own variance here). a2rl's fixes (1-3 cm measured) lie 0.4-0.7 m from its SLAM for
  // 17 s: followed, its fixes held out beyond its outage lie 0.080 / 0.429 m (MAE / MAX) from
  // the result; kept out as claiming nothing, 0.088 / 0.498 m, the fused trajectory 0.52 m from
  // a fix held out there.
  for (std::size_t k = a; k <= b; ++k) {
    const double c = std::isfinite(s_.claim[k]) ? s_.claim[k] : std::sqrt(s_.var[k].x());
    if (!(c <= kPreciseClaim)) return false;
  }
  return true;
}

bool Refinement::drawn(std::size_t a, std::size_t b, double unclaimed_noise) const {
  // Positions drawn through an outage, not measured: fixes without a std-dev whose positions
  // are far smoother than the drive's fixes without one (a2rl resamples its GNSS at the pose
  // stamps; through a 28 s outage the curve drawn lies up to 17 m off). Judged drawn wrongly,
  // a measured run merely stays out. The noise of a fix is read over kNoiseReach fixes either
  // side: of a long run, its inner fixes alone show the run's own.
  const std::size_t inner = b - a > 4 * kNoiseReach ? kNoiseReach : 0;
  std::vector<double> noise;
  for (std::size_t k = a + inner; k + inner <= b; ++k) {
    if (!std::isfinite(s_.claim[k]) && std::isfinite(s_.noise[k])) noise.push_back(s_.noise[k]);
  }
  return !noise.empty() && median(noise) < kDrawnShare * unclaimed_noise;
}

void Refinement::updateWeights() {
  // Each fix's posterior probability of being an inlier, from its smoothed residual.
  const double box = o_.outlier_box;
  const double outlier = o_.outlier_prior / (box * box * 0.4 * box);
  for (std::size_t j = 0; j < s_.size(); ++j) {
    double e2 = 0.0, det = 1.0;
    for (std::size_t a = 0; a < 3; ++a) {
      const double v = s_.var[j](static_cast<int>(a)) + sm_[a].P[j];
      const double e = s_.r[j](static_cast<int>(a)) - sm_[a].m[j];
      e2 += e * e / v;
      det *= kTwoPi * v;
    }
    const double inlier = (1.0 - o_.outlier_prior) * std::exp(-0.5 * e2) / std::sqrt(det);
    if (followed_[j]) continue;
    w_[j] = locked_[j] || !(inlier + outlier > 0.0) ? 0.0 : inlier / (inlier + outlier);
  }
}

void Refinement::updateSteps() {
  // Each step's posterior probability of being a bend (bend_ratio times the core's 1-sigma)
  // and, where the residuals alone showed one, a jump, from its smoothed increment.
  const double sj2 = o_.jump_sigma * o_.jump_sigma, b2 = o_.bend_ratio * o_.bend_ratio;
  for (std::size_t j = 1; j < s_.size(); ++j) {
    double core = 1.0, bend = 1.0, jump = 1.0;
    for (std::size_t a = 0; a < 3; ++a) {
      const Smoothed& sm = sm_[a];
      const double dm = sm.m[j] - sm.m[j - 1];
      const double e2 = dm * dm + sm.P[j] + sm.P[j - 1] - 2.0 * sm.C[j - 1];
      const double v = std::max(qOf(static_cast<int>(a)) * s_.step(j), 1e-300);
      core *= std::exp(-0.5 * e2 / v) / std::sqrt(kTwoPi * v);
      bend *= std::exp(-0.5 * e2 / (b2 * v)) / std::sqrt(kTwoPi * b2 * v);
      jump *= std::exp(-0.5 * e2 / sj2) / std::sqrt(kTwoPi * sj2);
    }
    const double jp = candidates_[j] != 0.0 ? o_.jump_prior : 0.0;
    const double pj = jp * jump, pb = o_.bend_prior * bend;
    const double total = pj + pb + (1.0 - jp - o_.bend_prior) * core;
    if (!(total > 0.0)) {  // beyond every component: the broadest takes it
      jump_[j] = candidates_[j] != 0.0 ? 1.0 : 0.0;
      bend_[j] = 1.0 - jump_[j];
      continue;
    }
    jump_[j] = pj / total;
    bend_[j] = pb / total;
  }
}

}  // namespace follow
}  // namespace flexcloud
