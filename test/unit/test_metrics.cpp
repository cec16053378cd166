// The robust spread the fusion takes the GNSS's noise from.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "flexcloud/metrics.h"

namespace flexcloud {
namespace {

/// 2 cm of white noise on 70 % of the values; the rest biased by 1-8 m (multipath) or far off.
std::vector<double> contaminated(std::size_t n, double sigma, double share, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, sigma);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> v;
  for (std::size_t i = 0; i < n; ++i) {
    double x = noise(rng);
    if (u(rng) < share) x += (u(rng) < 0.5 ? -1.0 : 1.0) * (1.0 + 7.0 * u(rng));
    v.push_back(x);
  }
  return v;
}

TEST(RobustSigma, TheGaussianCoreOfContaminatedValues) {
  std::mt19937 rng(5);
  const std::vector<double> clean = contaminated(4000, 0.02, 0.0, rng);
  EXPECT_NEAR(robustSigma(clean, 0.02), 0.02, 0.001);
  const std::vector<double> dirty = contaminated(4000, 0.02, 0.3, rng);
  EXPECT_NEAR(robustSigma(dirty, 0.02), 0.02, 0.0015);
  // The plain median absolute value is pulled up by half by the same values.
  std::vector<double> a;
  for (double x : dirty) a.push_back(std::abs(x));
  EXPECT_GT(median(a) / 0.6745, 0.028);
}

TEST(RobustSigma, TheSameFromAStartFarTooSmallOrTooLarge) {
  std::mt19937 rng(6);
  const std::vector<double> v = contaminated(4000, 0.05, 0.2, rng);
  const double right = robustSigma(v, 0.05);
  EXPECT_NEAR(robustSigma(v, 0.001), right, 0.002);  // a receiver's 1 mm taken literally
  EXPECT_NEAR(robustSigma(v, 1.0), right, 0.002);
  EXPECT_NEAR(right, 0.05, 0.004);
  EXPECT_TRUE(std::isnan(robustSigma({0.1, 0.2}, 1.0)));
}

}  // namespace
}  // namespace flexcloud
