// The clock offset from the heading profiles, and the two profiles together: known offsets on
// a synthetic winding drive whose SLAM frame is turned and whose heading drifts, none claimed
// on a straight road, and the rules that combine the speed's and the heading's offsets.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "flexcloud/fusion/clock_offset.h"

namespace flexcloud {
namespace {

struct Drive {
  Trajectory slam;
  std::vector<GnssPoint> gnss;
};

/// 300 s at an even 10 m/s; the road winds (turn rate 0.15 rad/s, period 30 s) unless
/// `straight`; poses at 10 Hz in a frame turned by 0.7 rad whose heading drifts by 1e-4 rad/s;
/// fixes at 10 Hz with 2 cm noise, stamped `offset` s before their pose (the fix stamped t is
/// the pose at t + offset). The antenna sits 1.5 m ahead of the pose.
Drive makeDrive(double offset, bool straight) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.02);
  const double dt = 0.01;
  const Eigen::Vector3d lever(1.5, 0.0, 0.0);
  Eigen::Vector3d truth = Eigen::Vector3d::Zero(), slam = Eigen::Vector3d::Zero();
  double heading = 0.0;
  Drive d;
  for (int k = 0; k <= 30000; ++k) {
    const double t = k * dt;
    const double drift = 1e-4 * t;
    const Eigen::Quaterniond body(Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()));
    const Eigen::Quaterniond frame(Eigen::AngleAxisd(0.7 + drift, Eigen::Vector3d::UnitZ()));
    if (k % 10 == 0) {
      Pose p;
      p.stamp = 1000.0 + t;
      p.position = slam;
      p.orientation = frame * body;
      d.slam.push_back(p);
      GnssPoint g;
      g.stamp = p.stamp - offset;
      g.position = truth + body * lever + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      d.gnss.push_back(g);
    }
    const Eigen::Vector3d step = body * Eigen::Vector3d(10.0 * dt, 0.0, 0.0);
    truth += step;
    slam += frame * step;
    if (!straight) heading += 0.15 * std::sin(2.0 * M_PI * t / 30.0) * dt;
  }
  return d;
}

TEST(ClockHeading, KnownOffsetsAreFound) {
  for (const double offset : {-0.3, 0.0, 0.12, 0.3}) {
    const Drive d = makeDrive(offset, false);
    const ClockOffsetEstimate e =
        estimateHeadingOffset(d.slam, Eigen::Vector3d(1.5, 0.0, 0.0), d.gnss, 0.0);
    ASSERT_TRUE(e.observable) << offset;
    EXPECT_NEAR(e.offset, offset, 0.002) << offset;
    EXPECT_LT(e.sigma, 0.002) << offset;
  }
}

// The antenna turns with the car: left out, its offset from the pose passes for a lag.
TEST(ClockHeading, TheLeverArmIsApplied) {
  const Drive d = makeDrive(0.2, false);
  const ClockOffsetEstimate with =
      estimateHeadingOffset(d.slam, Eigen::Vector3d(1.5, 0.0, 0.0), d.gnss, 0.0);
  const ClockOffsetEstimate without =
      estimateHeadingOffset(d.slam, Eigen::Vector3d::Zero(), d.gnss, 0.0);
  EXPECT_NEAR(with.offset, 0.2, 0.002);
  EXPECT_GT(std::abs(without.offset - 0.2), 0.05);
}

TEST(ClockHeading, NothingOnAStraightRoad) {
  const Drive d = makeDrive(0.2, true);
  const ClockOffsetEstimate e =
      estimateHeadingOffset(d.slam, Eigen::Vector3d(1.5, 0.0, 0.0), d.gnss, 0.0);
  EXPECT_FALSE(e.observable);
}

ClockOffsetEstimate profile(double offset, double sigma) {
  ClockOffsetEstimate e;
  e.offset = offset;
  e.sigma = sigma;
  e.observable = true;
  return e;
}

TEST(ClockCombined, AgreeingProfilesAreWeighedBySigma) {
  const ClockEstimate c = combineClock(profile(0.300, 0.004), profile(0.304, 0.002));
  EXPECT_FALSE(c.disagree);
  EXPECT_NEAR(c.offset, 0.3032, 1e-4);
  EXPECT_NEAR(c.sigma, std::hypot(1.0 / std::sqrt(1.0 / 16e-6 + 1.0 / 4e-6), kClockSystematic),
              1e-9);
  EXPECT_TRUE(c.observable);
}

// KITTI 10's LiDAR odometry: its speed lags by 12 ms, its heading leads by 8. They part by 20
// ms, within what a SLAM's own lag moves either by: the heading refines the speed's offset.
TEST(ClockCombined, AHeadingWithinTheSpeedsBoundRefinesIt) {
  const ClockEstimate c = combineClock(profile(0.012, 0.0068), profile(-0.0083, 0.0048));
  EXPECT_FALSE(c.disagree);
  const double ws = 1.0 / (0.0068 * 0.0068), wh = 1.0 / (0.0048 * 0.0048);
  EXPECT_NEAR(c.offset, (ws * 0.012 - wh * 0.0083) / (ws + wh), 1e-12);
  EXPECT_NEAR(c.sigma, std::hypot(1.0 / std::sqrt(ws + wh), kClockSystematic), 1e-12);
  EXPECT_FALSE(c.observable);  // told from 0 by neither: the stamps as given stand
  EXPECT_EQ(c.reason, "within its noise of 0");
}

// MulRan DCC_03: the speed profile 43.1 +- 4.6 ms (the truth 54 ms), the heading -214 +- 15 ms
// (its LiDAR's heading lags its path in turns). The heading lies far beyond the speed's bound
// and takes no part: the speed's offset stands with its own sigma.
TEST(ClockCombined, AHeadingBeyondTheSpeedsBoundTakesNoPart) {
  const ClockEstimate c = combineClock(profile(0.0431, 0.0046), profile(-0.2143, 0.0153));
  EXPECT_TRUE(c.disagree);
  EXPECT_DOUBLE_EQ(c.offset, 0.0431);
  EXPECT_NEAR(c.sigma, std::hypot(0.0046, kClockSystematic), 1e-12);
  EXPECT_TRUE(c.observable);
}

// A speed profile that knows the offset loosely (5 +- 29 ms, the truth 0) is not sharpened by a
// heading within its bound (-46 +- 4 ms): a heading that lags in turns would take the clock
// there.
TEST(ClockCombined, ALooseSpeedProfileIsNotRefinedByTheHeading) {
  const ClockEstimate c = combineClock(profile(0.005, 0.029), profile(-0.046, 0.004));
  EXPECT_FALSE(c.disagree);
  EXPECT_DOUBLE_EQ(c.offset, 0.005);
  EXPECT_NEAR(c.sigma, std::hypot(0.029, kClockSystematic), 1e-12);
  EXPECT_FALSE(c.observable);
}

TEST(ClockCombined, TheSpeedAloneIsEnoughTheHeadingAloneIsNot) {
  ClockOffsetEstimate none;
  const ClockEstimate speed = combineClock(profile(0.1, 0.003), none);
  EXPECT_DOUBLE_EQ(speed.offset, 0.1);
  EXPECT_TRUE(speed.observable);
  const ClockEstimate heading = combineClock(none, profile(0.1, 0.003));
  EXPECT_FALSE(heading.observable);
  EXPECT_EQ(heading.reason,
            "the speed varies too little to show it (the heading alone could take a wandering "
            "SLAM heading for one)");
  const ClockEstimate neither = combineClock(none, none);
  EXPECT_FALSE(neither.observable);
  EXPECT_FALSE(std::isfinite(neither.sigma));
  EXPECT_EQ(neither.reason, "neither the speed nor the heading varies enough to show it");
}

// KITTI 03's LiDAR odometry, whose true offset is 0: its speed lags by 22.6 +- 6.7 ms, its
// heading by 28 +- 29. Told from 0, not from a SLAM's own lag: the stamps as given stand. The
// same profiles at 30 ms and 4 ms sigmas are a clock.
TEST(ClockCombined, AnOffsetNoLargerThanASlamsOwnLagIsNotApplied) {
  const ClockEstimate c = combineClock(profile(0.0226, 0.0067), profile(0.028, 0.029));
  EXPECT_GT(std::abs(c.offset), kClockSignificant * c.sigma);  // beyond its noise
  EXPECT_FALSE(c.observable);
  EXPECT_TRUE(c.within_lag);
  EXPECT_EQ(c.reason,
            "no more than a SLAM's own lag can show in its speed and heading (30 ms at this "
            "sigma)");
  const ClockEstimate clock = combineClock(profile(0.030, 0.004), profile(0.030, 0.004));
  EXPECT_TRUE(clock.observable);
  EXPECT_FALSE(clock.within_lag);
  EXPECT_TRUE(clock.reason.empty());
  // The bound: k times the sigma and the lag together.
  EXPECT_TRUE(beyondSlamLag(0.0251, 0.0, 2.0));
  EXPECT_FALSE(beyondSlamLag(0.0249, 0.0, 2.0));
  EXPECT_FALSE(beyondSlamLag(-0.030, 0.01, 2.0));  // 2 * hypot(10, 12.5) = 32 ms
  EXPECT_TRUE(beyondSlamLag(-0.033, 0.01, 2.0));
}

// KITTI 02 with 1 Hz urban GNSS, its poses' stamps 0.1 s off: the speed alone, 71 +- 34 ms.
// Not told from a SLAM's own lag, but known so loosely that the stamps as given may be far off:
// loose, for the fusion's fit of positions to decide. The same at 10 ms is not.
TEST(ClockCombined, AnOffsetKnownLooselyIsLeftToTheFit) {
  const ClockOffsetEstimate none;
  const ClockEstimate c = combineClock(profile(0.0709, 0.0336), none);
  EXPECT_FALSE(c.observable);
  EXPECT_TRUE(c.loose);
  EXPECT_NEAR(c.sigma, std::hypot(0.0336, kClockSystematic), 1e-12);
  EXPECT_EQ(c.reason,
            "no more than a SLAM's own lag can show in its speed and heading (72 ms at "
            "this sigma)");
  const ClockEstimate tight = combineClock(profile(0.0100, 0.0100), none);
  EXPECT_FALSE(tight.observable);
  EXPECT_FALSE(tight.loose);
  EXPECT_EQ(tight.reason, "within its noise of 0");
  // Not even the speed shows it: nothing for the fit to start from.
  EXPECT_FALSE(combineClock(none, none).loose);
}

}  // namespace
}  // namespace flexcloud
