// The judge of the pose sigmas (sim/truth_metrics.h): the shares within the 95 % regions, the
// independent samples a drive's errors amount to, and the band calibrated sigmas show.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "flexcloud/sim/truth_metrics.h"

namespace flexcloud::sim {
namespace {

TEST(SigmaCoverage, CountsThePosesWithinTheCircleAndTheVerticalBand) {
  // Horizontal errors of 2.0 and 3.0 m against a sigma of 1 m: inside and outside 2.45;
  // vertical 1.9 and 2.0 m: inside and outside 1.96.
  const std::vector<Eigen::Vector3d> errors = {{1.2, 1.6, 1.9}, {0.0, 3.0, -2.0}};
  const SigmaCoverage c = sigmaCoverage(errors, {1.0, 1.0}, {1.0, 1.0});
  EXPECT_EQ(c.poses, 2.0);
  EXPECT_EQ(c.within_h, 1.0);
  EXPECT_EQ(c.within_v, 1.0);
  EXPECT_DOUBLE_EQ(c.shareH(), 0.5);
  EXPECT_DOUBLE_EQ(c.shareV(), 0.5);
}

TEST(SigmaCoverage, ErrorsAlikeOverBlocksCountOnceAPerBlock) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  const std::size_t poses = 20000;
  std::vector<Eigen::Vector3d> white, blocks;
  Eigen::Vector3d held = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < poses; ++i) {
    white.emplace_back(n(rng), n(rng), n(rng));
    if (i % 20 == 0) held = Eigen::Vector3d(n(rng), n(rng), n(rng));
    blocks.push_back(held);
  }
  const std::vector<double> one(poses, 1.0);
  const SigmaCoverage w = sigmaCoverage(white, one, one);
  EXPECT_DOUBLE_EQ(w.independent_h, static_cast<double>(poses));  // decorrelated at lag 1
  EXPECT_DOUBLE_EQ(w.independent_v, static_cast<double>(poses));
  // White N(0, 1) errors against sigmas of 1: 95 % within either region.
  EXPECT_NEAR(w.shareH(), 0.95, 0.005);
  EXPECT_NEAR(w.shareV(), 0.95, 0.005);
  // Held over 20 poses, their autocorrelation at lag k is 1 - k / 20: below 1/e from lag 13.
  const SigmaCoverage b = sigmaCoverage(blocks, one, one);
  EXPECT_NEAR(b.independent_h, poses / 13.0, 0.05 * poses / 13.0);
  EXPECT_NEAR(b.independent_v, poses / 13.0, 0.05 * poses / 13.0);
}

TEST(SigmaCoverage, PooledDrivesAddTheirCounts) {
  SigmaCoverage a{10.0, 9.0, 8.0, 5.0, 2.0}, b{30.0, 30.0, 27.0, 15.0, 3.0};
  a += b;
  EXPECT_EQ(a.poses, 40.0);
  EXPECT_EQ(a.within_h, 39.0);
  EXPECT_EQ(a.within_v, 35.0);
  EXPECT_EQ(a.independent_h, 20.0);
  EXPECT_EQ(a.independent_v, 5.0);
}

TEST(SigmaCoverage, TheCalibratedBandNarrowsWithTheSamples) {
  // 0.95 -+ 2.576 sqrt(0.0475 / n): n = 100 gives 0.8939 and 1.0061, held at 1.
  const CoverageBand hundred = calibratedBand(100.0);
  EXPECT_NEAR(hundred.low, 0.89386, 1e-4);
  EXPECT_DOUBLE_EQ(hundred.high, 1.0);
  const CoverageBand many = calibratedBand(10000.0);
  EXPECT_NEAR(many.low, 0.94439, 1e-4);
  EXPECT_NEAR(many.high, 0.95561, 1e-4);
  const CoverageBand none = calibratedBand(0.0);
  EXPECT_EQ(none.low, 0.0);
  EXPECT_EQ(none.high, 1.0);
}

}  // namespace
}  // namespace flexcloud::sim
