// The random walk behind the pose sigmas against closed forms and a simulated walk, and the
// sigmas' shape: least where fixes are dense, growing across a gap and beyond the last fix.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "flexcloud/uncertainty/pose_sigma.h"
#include "uncertainty/random_walk.h"

namespace flexcloud {
namespace {

// Two observations 10 m apart: the smoothed variance at the first is that of two readings of
// the level, one of them through the walk's 10 m: 1 / (1/R1 + 1/(R2 + 10 q)), with the broad
// prior's share (1e-4 relative) left in the tolerance.
TEST(RandomWalk, TwoObservationsMatchTheClosedForm) {
  walk::Series s{{0.0, 0.0}, {0.04, 0.09}, {0.0, 10.0}};
  const double q = 0.002;
  const std::vector<double> v = walk::smoothedVariance(s, {q, 0.0});
  ASSERT_EQ(v.size(), 2u);
  EXPECT_NEAR(v[0], 1.0 / (1.0 / 0.04 + 1.0 / (0.09 + 10.0 * q)), 1e-5);
  EXPECT_NEAR(v[1], 1.0 / (1.0 / 0.09 + 1.0 / (0.04 + 10.0 * q)), 1e-5);
}

// Dense, evenly spaced observations of a walk: in the middle of the series the smoothed
// variance joins the forward filter's steady state (P_f = (-qd + sqrt(qd^2 + 4 qd R)) / 2)
// with the backward filter's prediction to the same place (P_f + qd, by symmetry).
TEST(RandomWalk, SteadyStateOfADenseSeries) {
  walk::Series s;
  const double r = 0.01, q = 1e-4, d = 1.0;
  for (int i = 0; i < 400; ++i) {
    s.value.push_back(0.0), s.var.push_back(r), s.along.push_back(i * d);
  }
  const double qd = q * d;
  const double pf = (-qd + std::sqrt(qd * qd + 4.0 * qd * r)) / 2.0;  // filtered
  const double pp = pf + qd;                                          // predicted
  // Smoothed at a middle observation: the filtered one combined with the backward filter's
  // prediction, which is pp by symmetry.
  const double ps = 1.0 / (1.0 / pf + 1.0 / pp);
  const std::vector<double> v = walk::smoothedVariance(s, {q, 0.0});
  EXPECT_NEAR(v[200], ps, 1e-3 * ps);
}

// A simulated walk of known intensity read through white noise: learned within 25 %.
TEST(RandomWalk, LearnsTheIntensityOfASimulatedWalk) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  const double q = 4e-4, r = 0.02 * 0.02;
  walk::Series x, y;
  double wx = 0.0, wy = 0.0;
  for (int i = 0; i < 6000; ++i) {
    wx += std::sqrt(q) * n(rng), wy += std::sqrt(q) * n(rng);
    x.value.push_back(wx + 0.02 * n(rng)), y.value.push_back(wy + 0.02 * n(rng));
    x.var.push_back(r), y.var.push_back(r);
    x.along.push_back(i), y.along.push_back(i);
  }
  const walk::Intensity learned = walk::learnIntensity({x, y});
  EXPECT_NEAR(learned.value / q, 1.0, 0.25) << learned.value;
  EXPECT_LT(learned.rate, 1e-7) << learned.rate;  // no bend to speak of
}

// A correction that only bends (its rate wanders, 1e-7 m^2 per m^3) read through 2 cm of white
// noise every metre: the rate's intensity is learned within a factor of two, the value's stays
// far below what a plain walk would need, and the smoother pins the correction down to better
// than the fixes' noise over ten of them.
TEST(RandomWalk, LearnsABendingCorrection) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  const double q_rate = 1e-7;
  walk::Series x;
  double value = 0.0, rate = 0.0;
  for (int i = 0; i < 5000; ++i) {
    rate += std::sqrt(q_rate) * n(rng);
    value += rate;
    x.value.push_back(value + 0.02 * n(rng));
    x.var.push_back(0.02 * 0.02);
    x.along.push_back(i);
  }
  const walk::Intensity learned = walk::learnIntensity({x});
  EXPECT_GT(learned.rate, 0.5 * q_rate);
  EXPECT_LT(learned.rate, 2.0 * q_rate);
  EXPECT_LT(learned.value, 1e-5);  // a plain walk would take about 1e-4
  const std::vector<double> v = walk::smoothedVariance(x, learned);
  EXPECT_LT(std::sqrt(v[2500]), 0.02 / std::sqrt(10.0));
}

Trajectory straight(int n, double step) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    Pose p;
    p.stamp = 0.1 * i;
    p.position = Eigen::Vector3d(step * i, 0.0, 0.0);
    t.push_back(p);
  }
  return t;
}

// 1 km at 10 m/s, the SLAM drifting as a walk of 5 cm per square root of a metre, a fix every
// 1 m with 2 cm of noise but none from 300 to 500 m or beyond 900 m: the sigma is least among the
// fixes, largest in the middle of the gap, and grows past the last fix.
TEST(PoseSigmas, GrowInGapsAndBeyondTheLastFix) {
  const Trajectory t = straight(1001, 1.0);  // the truth, and the result that follows it
  Trajectory slam = t;
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 0.02);
  std::vector<SigmaFix> fixes;
  double drift = 0.0;
  for (int i = 0; i <= 1000; ++i) {
    drift += 2.5 * n(rng);  // n is 2 cm: 5 cm per metre
    slam[i].position.x() -= drift;
    if ((i > 300 && i < 500) || i > 900) continue;
    fixes.push_back(
        {t[i].stamp, t[i].position + Eigen::Vector3d(n(rng), n(rng), n(rng)), 0.02, 0.02});
  }
  const PoseSigmas s = poseSigmas(t, slam, fixes);
  ASSERT_EQ(s.h.size(), t.size());
  EXPECT_EQ(s.fixes, fixes.size());
  EXPECT_LT(s.h[150], s.h[400]);
  EXPECT_GT(s.h[400], s.h[320]);
  EXPECT_GT(s.h[1000], s.h[950]);
  EXPECT_GT(s.h[950], s.h[890]);
  EXPECT_LT(s.h[150], 0.03);
  EXPECT_GE(s.worst.from, t[300].stamp);
  EXPECT_LE(s.worst.to, t[1000].stamp);
  EXPECT_DOUBLE_EQ(s.worst.sigma_h, *std::max_element(s.h.begin(), s.h.end()));
}

// A clock held at the stamps as given (SigmaContext::held_clock_sigma, 50 ms at 10 m/s: 0.5 m
// along the track) counts where the fixes are imprecise (0.5 m, one a second), whose noise hides
// it, at most doubling the variance they leave; among RTK fixes (2 cm, ten a second), which would
// show it, not at all.
TEST(PoseSigmas, AClockHeldAtTheStampsCountsWhereTheFixesHideIt) {
  const Trajectory t = straight(1001, 1.0);
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  for (const double std_dev : {0.5, 0.02}) {
    std::vector<SigmaFix> fixes;
    for (std::size_t i = 0; i<t.size(); i += std_dev> 0.1 ? 10 : 1) {
      const Eigen::Vector3d e = std_dev * Eigen::Vector3d(n(rng), n(rng), n(rng));
      fixes.push_back({t[i].stamp, t[i].position + e, std_dev, std_dev});
    }
    SigmaContext held;
    held.held_clock_sigma = 0.05;
    const PoseSigmas plain = poseSigmas(t, t, fixes), with = poseSigmas(t, t, fixes, held);
    for (const std::size_t i : {100u, 500u, 900u}) {
      if (std_dev > 0.1) {
        EXPECT_GT(with.h[i], plain.h[i] + 0.005) << i;
        EXPECT_LE(with.h[i], std::sqrt(2.0) * plain.h[i]) << i;
      } else {
        EXPECT_DOUBLE_EQ(with.h[i], plain.h[i]) << i;
      }
      EXPECT_DOUBLE_EQ(with.v[i], plain.v[i]) << i;
    }
  }
}

// A GNSS/INS at 10 Hz whose error wanders smoothly (3 cm per axis, over 20 s) beside 5 mm of
// white noise, its receiver reporting 3 cm: the result follows the fixes and so their wander.
// Read as white noise, a thousand fixes pin each pose down to a few millimetres, and fewer than
// half of the result's errors lie within the sigmas; with what the receiver reported beyond the
// white noise as an error the fixes share, 90 % or more do, horizontally and vertically, and the
// median sigma stays within twice the error's RMSE per axis.
TEST(PoseSigmas, TheErrorTheFixesShareIsNotAveragedOut) {
  const Trajectory truth = straight(3001, 1.0);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  const double wander = 0.03, white = 0.005, tau = 20.0, dt = 0.1;
  const double keep = std::exp(-dt / tau), drive = wander * std::sqrt(1.0 - keep * keep);
  Trajectory result = truth;
  std::vector<SigmaFix> plain, shared;
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < truth.size(); ++i) {
    for (int a = 0; a < 3; ++a) e(a) = keep * e(a) + drive * n(rng);
    result[i].position += e;
    const Eigen::Vector3d fix =
        truth[i].position + e + white * Eigen::Vector3d(n(rng), n(rng), n(rng));
    plain.push_back({truth[i].stamp, fix, white, white});
    shared.push_back({truth[i].stamp, fix, white, white, wander, wander});
  }
  const auto cover = [&](const PoseSigmas& s, double& h, double& v, double& rms) {
    h = v = rms = 0.0;
    for (std::size_t i = 0; i < result.size(); ++i) {
      const Eigen::Vector3d d = result[i].position - truth[i].position;
      h += d.head<2>().norm() <= 2.45 * s.h[i];
      v += std::abs(d.z()) <= 1.96 * s.v[i];
      rms += 0.5 * d.head<2>().squaredNorm();
    }
    const auto count = static_cast<double>(result.size());
    h /= count, v /= count, rms = std::sqrt(rms / count);
  };
  double h = 0.0, v = 0.0, rms = 0.0;
  cover(poseSigmas(result, truth, plain), h, v, rms);
  std::printf("read as white: %.1f / %.1f %% within 2.45 / 1.96 sigma\n", 100.0 * h, 100.0 * v);
  EXPECT_LT(h, 0.5);
  EXPECT_LT(v, 0.5);
  const PoseSigmas s = poseSigmas(result, truth, shared);
  cover(s, h, v, rms);
  std::printf("shared: %.1f / %.1f %%, median sigma %.4f m, RMSE per axis %.4f m\n", 100.0 * h,
              100.0 * v, s.median_h, rms);
  EXPECT_GE(h, 0.9);
  EXPECT_GE(v, 0.9);
  EXPECT_GE(s.median_h, wander);
  EXPECT_LE(s.median_h, 2.0 * rms);
}

// Fixes that claimed RTK precision and agree with each other, 1.5 m off the result from 400 to
// 500 m and rejected: the GNSS's word against the SLAM's. The result does not rest on them, but
// how far it lies from them counts there: its sigma covers the 1.5 m (at least 0.6 m), and away
// from them, where the result rests on good fixes, the sigmas are those without the dispute.
TEST(PoseSigmas, ADisputedStretchCountsWhereItLies) {
  const Trajectory t = straight(1001, 1.0);
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0.0, 0.02);
  std::vector<SigmaFix> fixes, agreed;
  for (int i = 0; i <= 1000; ++i) {
    SigmaFix f{t[i].stamp, t[i].position + Eigen::Vector3d(n(rng), n(rng), n(rng)), 0.02, 0.02};
    if (i > 400 && i < 500) {
      f.position.y() += 1.5;
      f.disputed = true;
    } else {
      agreed.push_back(f);
    }
    fixes.push_back(f);
  }
  const PoseSigmas with = poseSigmas(t, t, fixes), without = poseSigmas(t, t, agreed);
  EXPECT_EQ(with.fixes, agreed.size());
  EXPECT_GT(with.h[450], 0.6);
  EXPECT_GT(2.45 * with.h[450], 1.5);
  EXPECT_LT(without.h[450], 0.1);
  EXPECT_NEAR(with.h[200], without.h[200], 1e-9);
  EXPECT_NEAR(with.h[800], without.h[800], 1e-9);
}

// No fix the result rests on: nothing is known, and that is what is said.
TEST(PoseSigmas, WithoutFixesEverySigmaIsInfinite) {
  const Trajectory t = straight(10, 1.0);
  const PoseSigmas s = poseSigmas(t, t, {});
  ASSERT_EQ(s.h.size(), 10u);
  EXPECT_TRUE(std::isinf(s.h[3]));
  EXPECT_TRUE(std::isinf(s.median_h));
}

}  // namespace
}  // namespace flexcloud
