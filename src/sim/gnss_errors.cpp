#include "flexcloud/sim/gnss_errors.h"

#include <cmath>
#include <limits>

namespace flexcloud::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Number of events for a rate per km: the integer part, plus one more with the fraction's
/// probability.
int countFor(double per_km, double length, std::mt19937_64& rng) {
  const double expected = per_km * length / 1000.0;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return static_cast<int>(std::floor(expected)) + (u(rng) < expected - std::floor(expected));
}

}  // namespace

GnssErrors urbanGnss() {
  GnssErrors e;
  e.multipath_per_km = 1.0;
  e.float_per_km = 0.4;
  e.outlier_share = 0.02;
  return e;
}

GnssErrorModel::GnssErrorModel(const GnssErrors& e, double duration, double length,
                               const Eigen::Vector3d& rtk_std, std::uint64_t seed)
    : e_(e),
      duration_(duration),
      correlated_rng_(seed ^ 0x1c0aa7edull),
      rtk_std_(rtk_std),
      rng_(seed ^ 0x6e55e770ull) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto between = [&](double a, double b) { return a + (b - a) * u(rng_); };
  for (int i = countFor(e.multipath_per_km, length, rng_); i > 0; --i) {
    Episode ep;
    ep.duration = between(e.multipath_min_s, e.multipath_max_s);
    ep.start = between(0.0, std::max(0.0, duration - ep.duration));
    ep.peak = between(e.multipath_min_m, e.multipath_max_m);
    ep.heading = between(0.0, 2.0 * kPi);
    ep.turn_rate = between(-0.05, 0.05);
    ep.vertical = (u(rng_) < 0.5 ? -1.0 : 1.0) * e.multipath_vertical;
    ep.false_rtk = u(rng_) < e.false_rtk_share;
    episodes_.push_back(ep);
  }
  for (int i = countFor(e.float_per_km, length, rng_); i > 0; --i) {
    const double d = between(e.float_min_s, e.float_max_s);
    floats_.push_back({between(0.0, std::max(0.0, duration - d)), d});
  }
}

Eigen::Vector3d GnssErrorModel::episodeBias(const Episode& e, double t) const {
  const double tau = t - e.start;
  if (tau < 0.0 || tau > e.duration) return Eigen::Vector3d::Zero();
  const double s = std::sin(kPi * tau / e.duration);
  const double a = e.peak * s * s;
  const double h = e.heading + e.turn_rate * tau;
  return Eigen::Vector3d(a * std::cos(h), a * std::sin(h), a * e.vertical);
}

Eigen::Vector3d GnssErrorModel::correlatedAt(double t) {
  std::normal_distribution<double> n01(0.0, 1.0);
  const Eigen::Vector3d sigma(e_.correlated_m, e_.correlated_m, 2.0 * e_.correlated_m);
  const Eigen::Vector3d draw(n01(correlated_rng_), n01(correlated_rng_), n01(correlated_rng_));
  // The first sample is drawn from the process's steady state.
  const double a =
      correlated_started_ ? std::exp(-std::max(0.0, t - correlated_t_) / e_.correlated_tau_s) : 0.0;
  correlated_ = a * correlated_ + std::sqrt(1.0 - a * a) * sigma.cwiseProduct(draw);
  correlated_started_ = true;
  correlated_t_ = t;
  return correlated_;
}

GnssErrorSample GnssErrorModel::at(double t) {
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  GnssErrorSample s;
  s.reported_std = rtk_std_;
  // Part of the receiver's normal error: it does not make the fix abnormal.
  if (e_.correlated_m > 0.0) s.error += correlatedAt(t);
  for (const auto& ep : episodes_) {
    const Eigen::Vector3d b = episodeBias(ep, t);
    if (b.isZero()) continue;
    s.error += b + e_.multipath_jitter * Eigen::Vector3d(n01(rng_), n01(rng_), n01(rng_));
    if (!ep.false_rtk) s.reported_std = Eigen::Vector3d::Constant(e_.multipath_std);
    s.normal = false;
  }
  for (const auto& f : floats_) {
    if (t < f.start || t > f.start + f.duration) continue;
    s.error += e_.float_noise * Eigen::Vector3d(n01(rng_), n01(rng_), n01(rng_));
    s.reported_std = s.reported_std.cwiseMax(Eigen::Vector3d::Constant(e_.float_std));
    s.normal = false;
  }
  if (e_.end_false_rtk_s > 0.0 && t > duration_ - e_.end_false_rtk_s) {
    const double ramp = std::min(1.0, (t - (duration_ - e_.end_false_rtk_s)) / 2.0);
    s.error += ramp * e_.end_bias_m * Eigen::Vector3d(0.8, 0.6, 0.3);
    s.normal = false;
  }
  if (u(rng_) < e_.outlier_share) {
    const double m = e_.outlier_min_m + (e_.outlier_max_m - e_.outlier_min_m) * u(rng_);
    const double h = 2.0 * kPi * u(rng_);
    s.error += m * Eigen::Vector3d(std::cos(h), std::sin(h), 0.3 * n01(rng_));
    if (u(rng_) >= e_.outlier_false_rtk_share) {
      s.reported_std = Eigen::Vector3d::Constant(0.5 * m);
    }
    s.normal = false;
  }
  if (u(rng_) < e_.no_covariance_share) {
    s.reported_std.setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return s;
}

}  // namespace flexcloud::sim
