#include <gtest/gtest.h>

#include <random>

#include "flexcloud/sheet/alignment.h"

namespace flexcloud {
namespace {

std::vector<Eigen::Vector3d> cloud(int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-500.0, 500.0);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < n; ++i) pts.emplace_back(u(rng), u(rng), 0.05 * u(rng));
  return pts;
}

Eigen::Matrix3d knownRotation() {
  return (Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(-0.03, Eigen::Vector3d::UnitY()))
      .toRotationMatrix();
}

TEST(Umeyama, RecoversAKnownRigidTransform) {
  const auto src = cloud(200, 1);
  const Eigen::Matrix3d r = knownRotation();
  const Eigen::Vector3d t(123456.7, -9876.5, 43.2);
  std::vector<Eigen::Vector3d> dst;
  for (const auto& p : src) dst.push_back(r * p + t);
  const Similarity s = umeyama(src, dst, {}, false);
  EXPECT_LT((s.rotation - r).norm(), 1e-9);
  EXPECT_LT((s.translation - t).norm(), 1e-9 * t.norm());
  EXPECT_DOUBLE_EQ(s.scale, 1.0);
}

TEST(Umeyama, RecoversAKnownSimilarityScale) {
  const auto src = cloud(100, 2);
  const Eigen::Matrix3d r = knownRotation();
  std::vector<Eigen::Vector3d> dst;
  for (const auto& p : src) dst.push_back(1.002 * r * p + Eigen::Vector3d(5, 6, 7));
  const Similarity s = umeyama(src, dst, {}, true);
  EXPECT_NEAR(s.scale, 1.002, 1e-12);
  EXPECT_LT((s.rotation - r).norm(), 1e-9);
}

TEST(Umeyama, WeightsDecide) {
  auto src = cloud(50, 3);
  std::vector<Eigen::Vector3d> dst = src;
  std::vector<double> w(src.size(), 1.0);
  dst[0] += Eigen::Vector3d(100.0, 0.0, 0.0);  // an outlier with no weight changes nothing
  w[0] = 0.0;
  const Similarity s = umeyama(src, dst, w, false);
  EXPECT_LT((s.rotation - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_LT(s.translation.norm(), 1e-9);
}

TEST(Umeyama, StraightLineTakesTheSmallestRotation) {
  std::vector<Eigen::Vector3d> src, dst;
  const Eigen::Matrix3d r(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()));
  for (int i = 0; i < 20; ++i) {
    src.emplace_back(10.0 * i, 0.0, 0.0);
    dst.push_back(r * src.back() + Eigen::Vector3d(1, 2, 3));
  }
  const Similarity s = umeyama(src, dst, {}, false);
  EXPECT_LT((s.rotation - r).norm(), 1e-9);  // no roll about the line is invented
}

TEST(Umeyama, TooFewOrCoincidentPointsAreAnError) {
  EXPECT_THROW(umeyama({{0, 0, 0}, {1, 0, 0}}, {{0, 0, 0}, {1, 0, 0}}, {}, false), Error);
  EXPECT_THROW(
      umeyama({{1, 1, 1}, {1, 1, 1}, {1, 1, 1}}, {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {}, false),
      Error);
}

}  // namespace
}  // namespace flexcloud
