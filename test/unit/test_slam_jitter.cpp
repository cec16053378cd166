// The SLAM's pose-to-pose error from the fixes' third differences.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "flexcloud/fusion/slam_jitter.h"

namespace flexcloud {
namespace {

using Vec3 = Eigen::Vector3d;

/// A curving, climbing track sampled every 0.2 s at 12 m/s (no noise).
std::vector<Vec3> track(std::size_t n) {
  std::vector<Vec3> out;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = 0.2 * static_cast<double>(i), a = 0.02 * t;
    out.emplace_back(600.0 * std::sin(a), 600.0 * (1.0 - std::cos(a)), 3.0 * std::sin(0.05 * t));
  }
  return out;
}

/// The SLAM: the track under a slowly growing drift (a rotation of 0.5 degrees over the drive
/// and an offset), plus white jitter of `h` / `v` metres.
std::vector<Vec3> slamOf(const std::vector<Vec3>& truth, double h, double v, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Vec3> out;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const double yaw = 0.0087 * static_cast<double>(i) / static_cast<double>(truth.size());
    const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
    out.push_back(r * truth[i] + Vec3(2.0, -1.0, 0.5) + Vec3(h * n(rng), h * n(rng), v * n(rng)));
  }
  return out;
}

std::vector<Vec3> noisy(const std::vector<Vec3>& x, double sigma, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, sigma);
  std::vector<Vec3> out = x;
  for (auto& p : out) p += Vec3(n(rng), n(rng), n(rng));
  return out;
}

/// The stamps of track(n): every 0.2 s.
std::vector<double> stamps(std::size_t n) {
  std::vector<double> t;
  for (std::size_t i = 0; i < n; ++i) t.push_back(0.2 * static_cast<double>(i));
  return t;
}

double medianOf(const std::vector<Vec3>& j, int axis) {
  std::vector<double> v;
  for (const auto& x : j) v.push_back(x(axis));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// A track's roughness is its white noise: the curving, climbing motion leaves next to nothing.
TEST(SlamJitter, TheRoughnessOfATrackIsItsWhiteNoise) {
  std::mt19937 rng(11);
  const Eigen::Vector2d r = roughness(noisy(track(3000), 0.05, rng), stamps(3000));
  EXPECT_NEAR(r.x(), 0.05, 0.004);
  EXPECT_NEAR(r.y(), 0.05, 0.006);
  EXPECT_LT(roughness(track(3000), stamps(3000)).maxCoeff(), 1e-3);
  EXPECT_TRUE(std::isnan(roughness(track(3), stamps(3)).x()));
}

/// Dropped and thinned fixes leave the roughness as it was: the third differences are taken at
/// the fixes' own stamps (consecutive ones across a gap would hold the motion of the gap).
TEST(SlamJitter, DroppedFixesDoNotRaiseTheRoughness) {
  std::mt19937 rng(12);
  const std::vector<Vec3> all = noisy(track(3000), 0.05, rng);
  const std::vector<double> t = stamps(3000);
  std::vector<Vec3> kept;
  std::vector<double> kept_t;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (i % 3 == 1 || u(rng) < 0.2) continue;  // every third and a fifth of the rest
    kept.push_back(all[i]);
    kept_t.push_back(t[i]);
  }
  const Eigen::Vector2d r = roughness(kept, kept_t);
  EXPECT_NEAR(r.x(), 0.05, 0.006);
  EXPECT_NEAR(r.y(), 0.05, 0.008);
}

TEST(SlamJitter, NoneWhereTheSlamIsSmoothWhateverTheGnssNoise) {
  std::mt19937 rng(3);
  const std::vector<Vec3> truth = track(1500);
  for (const double gnss : {0.01, 0.3}) {
    const std::vector<Vec3> j = slamJitter(noisy(truth, gnss, rng), slamOf(truth, 0, 0, rng),
                                           stamps(truth.size()), 10, 0.01);
    std::size_t moved = 0;
    for (const auto& x : j) moved += x.norm() > 0.0 ? 1 : 0;
    EXPECT_EQ(medianOf(j, 0), 0.0) << gnss;
    EXPECT_EQ(medianOf(j, 2), 0.0) << gnss;
    EXPECT_LT(moved, j.size() / 10) << gnss;  // the sampling noise of two spreads, rarely 1.5x
  }
}

TEST(SlamJitter, MeasuresAVerticalJitterOfTheSlamOnly) {
  std::mt19937 rng(5);
  const std::vector<Vec3> truth = track(1500);
  const std::vector<Vec3> j = slamJitter(noisy(truth, 0.01, rng), slamOf(truth, 0.0, 0.2, rng),
                                         stamps(truth.size()), 10, 0.01);
  EXPECT_NEAR(medianOf(j, 2), 0.2, 0.03);  // 1-sigma of the SLAM's vertical jitter
  EXPECT_EQ(medianOf(j, 0), 0.0);
  for (const auto& x : j) EXPECT_EQ(x.x(), x.y());
}

TEST(SlamJitter, AnIsolatedOutlierDoesNotShowAsJitter) {
  std::mt19937 rng(7);
  const std::vector<Vec3> truth = track(400);
  std::vector<Vec3> fixes = noisy(truth, 0.02, rng);
  fixes[200] += Vec3(8.0, -5.0, 3.0);
  const std::vector<Vec3> j =
      slamJitter(fixes, slamOf(truth, 0, 0, rng), stamps(truth.size()), 10, 0.01);
  for (std::size_t i = 190; i < 210; ++i) EXPECT_EQ(j[i].norm(), 0.0) << i;
}

}  // namespace
}  // namespace flexcloud
