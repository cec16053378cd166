#include <gtest/gtest.h>

#include "flexcloud/input/interpolation.h"
#include "flexcloud/params.h"

namespace flexcloud {
namespace {

Eigen::Vector3d cubic(double t) {
  return {2.0 + 3.0 * t - 0.5 * t * t + 0.07 * t * t * t, -1.0 + 0.2 * t * t * t,
          5.0 - 0.01 * t * t + 0.003 * t * t * t};
}

std::vector<GnssPoint> sample(const std::vector<double>& stamps, double std_dev = 0.02) {
  std::vector<GnssPoint> g;
  for (double t : stamps) {
    GnssPoint p;
    p.stamp = t;
    p.position = cubic(t);
    p.std_dev.setConstant(std_dev);
    g.push_back(p);
  }
  return g;
}

TEST(Interpolation, SplineIsExactOnACubic) {
  // Irregular GNSS stamps; the vehicle moves far enough between them for any spacing used.
  const auto gnss = sample({0.0, 0.2, 0.45, 0.6, 0.8, 1.1, 1.2, 1.4, 1.75, 2.0});
  Params p;
  p.min_spacing = 0.0;
  const std::vector<double> stamps{0.5, 0.61, 0.9, 1.15, 1.3, 1.5};
  const auto out = interpolateGnss(gnss, stamps, interpolationOptions(p));
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    ASSERT_TRUE(out[i].has_value()) << stamps[i];
    EXPECT_LT((out[i]->position - cubic(stamps[i])).norm(), 1e-9) << stamps[i];
    EXPECT_DOUBLE_EQ(out[i]->stamp, stamps[i]);
  }
}

TEST(Interpolation, ExactStampReturnsTheFix) {
  const auto gnss = sample({0.0, 1.0, 2.0, 3.0});
  const auto out = interpolateGnss(gnss, {1.0, 3.0}, interpolationOptions(Params{}));
  ASSERT_TRUE(out[0] && out[1]);
  EXPECT_EQ(out[0]->position, gnss[1].position);
  EXPECT_EQ(out[1]->position, gnss[3].position);
}

TEST(Interpolation, NoExtrapolationAndNoBridgingOfLongGaps) {
  const auto gnss = sample({10.0, 10.2, 10.4, 10.6, 13.0, 13.2, 13.4});
  Params p;
  p.max_gap = 1.0;
  const auto out = interpolateGnss(gnss, {9.9, 10.3, 11.5, 13.3, 13.5}, interpolationOptions(p));
  EXPECT_FALSE(out[0]);  // before the first fix
  EXPECT_TRUE(out[1]);
  EXPECT_FALSE(out[2]);  // inside a 2.4 s gap
  EXPECT_TRUE(out[3]);
  EXPECT_FALSE(out[4]);  // after the last fix
  p.max_gap = 3.0;
  EXPECT_TRUE(interpolateGnss(gnss, {11.5}, interpolationOptions(p))[0]);
}

TEST(Interpolation, NearTheEndsFewerSupportPointsStillInterpolate) {
  const auto gnss = sample({0.0, 0.2, 0.4});
  Params p;
  p.min_spacing = 0.0;
  const auto out = interpolateGnss(gnss, {0.1, 0.3}, interpolationOptions(p));
  ASSERT_TRUE(out[0] && out[1]);
  // A quadratic through three samples of the cubic: off by f'''/6 (t-0)(t-0.2)(t-0.4) per axis.
  const Eigen::Vector3d third(0.07, 0.2, 0.003);
  const Eigen::Vector3d want = cubic(0.1) - third * (0.1 * -0.1 * -0.3);
  EXPECT_LT((out[0]->position - want).norm(), 1e-12);
  // With the default 1 m spacing the third point (0.6 m away) is not taken: linear.
  const auto lin = interpolateGnss(gnss, {0.1}, interpolationOptions(Params{}));
  EXPECT_LT((lin[0]->position - 0.5 * (cubic(0.0) + cubic(0.2))).norm(), 1e-12);
}

TEST(Interpolation, MinimumSpacingSkipsOuterPointsOfAStandstill) {
  // The vehicle stands at x=0 until t=1, then moves at 1 m/s along x.
  std::vector<GnssPoint> gnss;
  for (int k = 0; k <= 30; ++k) {
    GnssPoint g;
    g.stamp = 0.1 * k;
    g.position = Eigen::Vector3d(std::max(0.0, g.stamp - 1.0), 0.0, 0.0);
    gnss.push_back(g);
  }
  Params p;
  p.min_spacing = 0.5;
  p.max_gap = 1.0;
  const auto out = interpolateGnss(gnss, {1.55}, interpolationOptions(p));
  ASSERT_TRUE(out[0]);
  // Support: 1.0 (standstill end, 0.5 m away), 1.5, 1.6, 2.1: all on the line x = t - 1.
  EXPECT_NEAR(out[0]->position.x(), 0.55, 1e-9);
}

TEST(Interpolation, StdDevFollowsTheWeights) {
  auto gnss = sample({0.0, 1.0, 2.0, 3.0}, 0.01);
  gnss[2].std_dev.setConstant(1.0);
  const auto out = interpolateGnss(gnss, {1.0, 1.5}, interpolationOptions(Params{}));
  EXPECT_DOUBLE_EQ(out[0]->std_dev.x(), 0.01);
  // Halfway between fixes 1 and 2 the cubic weights are -1/16, 9/16, 9/16, -1/16.
  EXPECT_NEAR(out[1]->std_dev.x(), 0.01 / 16 + 0.01 * 9 / 16 + 1.0 * 9 / 16 + 0.01 / 16, 1e-12);
}

TEST(Interpolation, NearestMode) {
  const auto gnss = sample({0.0, 1.0, 2.0});
  Params p;
  p.interpolation = InterpolationMode::kNearest;
  p.max_gap = 1.0;
  const auto out = interpolateGnss(gnss, {0.4, 0.6, 2.4, 2.6}, interpolationOptions(p));
  EXPECT_EQ(out[0]->position, gnss[0].position);
  EXPECT_EQ(out[1]->position, gnss[1].position);
  EXPECT_EQ(out[2]->position, gnss[2].position);
  EXPECT_FALSE(out[3]);  // 0.6 s from the nearest fix, more than max_gap / 2
}

}  // namespace
}  // namespace flexcloud
