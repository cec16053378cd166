// The SLAM's white jitter from pose to pose (input/jitter_smoothing.h): measured against a known
// jitter on a smooth path, taken out by the local cubic, and left alone where there is none,
// where the fixes share it, or where the poses are too sparse for a second's cubic.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "flexcloud/input/jitter_smoothing.h"

namespace flexcloud {
namespace {

/// A smooth drive at `rate` Hz: 12 m/s along a slow S-curve (radius about 100 m), gently
/// speeding up and down, rising and falling.
Trajectory smoothDrive(double rate, double seconds) {
  Trajectory t;
  for (int i = 0; i <= static_cast<int>(seconds * rate); ++i) {
    Pose p;
    p.stamp = 1000.0 + i / rate;
    const double s = p.stamp - 1000.0;
    const double along = 12.0 * s + 3.0 * std::sin(0.2 * s);
    p.position = Eigen::Vector3d(along, 40.0 * std::sin(along / 120.0), 2.0 * std::sin(s / 10.0));
    t.push_back(p);
  }
  return t;
}

Trajectory withJitter(Trajectory t, double sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, sigma);
  for (Pose& p : t) p.position += Eigen::Vector3d(n(rng), n(rng), n(rng));
  return t;
}

double rmsH(const Trajectory& a, const Trajectory& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sum += (a[i].position - b[i].position).head<2>().squaredNorm() / 2.0;
  }
  return std::sqrt(sum / static_cast<double>(a.size()));
}

TEST(JitterSmoothing, AKnownJitterIsMeasuredAndTakenOut) {
  const Trajectory truth = smoothDrive(10.0, 120.0);
  const Trajectory jittery = withJitter(truth, 0.015, 3);
  const JitterSmoothing s = measureJitter(jittery);
  EXPECT_TRUE(s.seen);
  EXPECT_NEAR(s.white, 0.015, 0.0015);
  EXPECT_LT(s.motion, 0.002);
  EXPECT_GE(s.half_width, 3);
  EXPECT_LE(s.half_width, 5);  // a second at most
  Trajectory smoothed = jittery;
  const std::vector<double> left = smoothJitter(smoothed, s.half_width);
  // A cubic through 9-11 poses keeps a quarter of the jitter's variance in the middle.
  EXPECT_NEAR(rmsH(jittery, truth), 0.015, 0.001);
  EXPECT_LT(rmsH(smoothed, truth), 0.55 * 0.015);
  EXPECT_LT(left[left.size() / 2], 0.55);
  EXPECT_GT(left[left.size() / 2], 0.4);
  EXPECT_LT(left.front(), 1.0);  // the ends too, by a window shifted inwards
  // The orientation and the stamps stay.
  for (std::size_t i = 0; i < smoothed.size(); ++i) {
    ASSERT_EQ(smoothed[i].stamp, jittery[i].stamp);
  }
}

TEST(JitterSmoothing, ASmoothSlamIsLeftAlone) {
  const Trajectory truth = smoothDrive(10.0, 120.0);
  const JitterSmoothing s = measureJitter(truth);
  EXPECT_FALSE(s.seen);
  EXPECT_EQ(s.half_width, 0);
  Trajectory same = truth;
  const std::vector<double> left = smoothJitter(same, s.half_width);
  EXPECT_EQ(rmsH(same, truth), 0.0);
  EXPECT_EQ(left, std::vector<double>(truth.size(), 1.0));
}

TEST(JitterSmoothing, PosesAtOneHertzAreNotSmoothed) {
  // Keyframes a second apart: a cubic over five of them spans 4 s, beyond a second.
  const Trajectory jittery = withJitter(smoothDrive(1.0, 600.0), 0.05, 5);
  EXPECT_EQ(measureJitter(jittery).half_width, 0);
}

TEST(JitterSmoothing, AJitterTheFixesShareIsNotTheSlams) {
  // Fixes stamped as the poses and off by the same error (stamps made up for both): the poses'
  // roughness is not their own.
  const Trajectory truth = smoothDrive(10.0, 120.0);
  const Trajectory shared = withJitter(truth, 0.02, 7);
  std::vector<GnssPoint> fixes;
  std::mt19937 rng(11);
  std::normal_distribution<double> own(0.0, 0.005);
  for (const Pose& p : shared) {
    GnssPoint g;
    g.stamp = p.stamp;
    g.position = p.position + Eigen::Vector3d(own(rng), own(rng), own(rng));
    fixes.push_back(g);
  }
  const JitterSmoothing s = measureJitter(shared, fixes);
  EXPECT_LT(s.own_share, 0.2);
  EXPECT_FALSE(s.seen);
  EXPECT_EQ(s.half_width, 0);
  // Fixes with errors of their own (RTK, 2 cm): the jitter is the poses' own.
  std::normal_distribution<double> rtk(0.0, 0.02);
  for (std::size_t i = 0; i < fixes.size(); ++i) {
    fixes[i].position = truth[i].position + Eigen::Vector3d(rtk(rng), rtk(rng), rtk(rng));
  }
  const JitterSmoothing t = measureJitter(shared, fixes);
  EXPECT_GT(t.own_share, 0.75);
  EXPECT_TRUE(t.seen);
}

TEST(JitterSmoothing, PosesKeptAreNeitherMovedNorSpanned) {
  const Trajectory truth = smoothDrive(10.0, 60.0);
  Trajectory jittery = withJitter(truth, 0.015, 13);
  // A jump of half a metre at pose 300: the poses next to it are kept.
  for (std::size_t i = 300; i < jittery.size(); ++i) jittery[i].position.x() += 0.5;
  std::vector<bool> keep(jittery.size(), false);
  keep[299] = keep[300] = true;
  Trajectory smoothed = jittery;
  const std::vector<double> left = smoothJitter(smoothed, 4, keep);
  EXPECT_EQ(smoothed[299].position, jittery[299].position);
  EXPECT_EQ(smoothed[300].position, jittery[300].position);
  EXPECT_EQ(left[300], 1.0);
  // No window reaches across the jump: the poses beside it keep their side's level.
  EXPECT_LT(std::abs(smoothed[298].position.x() - truth[298].position.x()), 0.05);
  EXPECT_LT(std::abs(smoothed[301].position.x() - truth[301].position.x() - 0.5), 0.05);
}

TEST(JitterSmoothing, APoseWithoutAFinitePositionSpreadsNothing) {
  const Trajectory truth = smoothDrive(10.0, 60.0);
  Trajectory jittery = withJitter(truth, 0.015, 17);
  jittery[200].position.x() = std::numeric_limits<double>::quiet_NaN();
  const JitterSmoothing s = measureJitter(jittery);
  ASSERT_GE(s.half_width, 2);
  Trajectory smoothed = jittery;
  smoothJitter(smoothed, s.half_width);
  EXPECT_TRUE(std::isnan(smoothed[200].position.x()));
  for (std::size_t i = 0; i < smoothed.size(); ++i) {
    if (i != 200) {
      ASSERT_TRUE(smoothed[i].position.allFinite()) << i;
    }
  }
  EXPECT_LT(rmsH(Trajectory(smoothed.begin(), smoothed.begin() + 190),
                 Trajectory(truth.begin(), truth.begin() + 190)),
            0.6 * 0.015);
}

}  // namespace
}  // namespace flexcloud
