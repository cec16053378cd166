#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "flexcloud/input/trajectory.h"
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

// A nearly straight drive (KITTI 04: 400 m, its GNSS a few centimetres off a line): the roll
// about the line is noise, and the fit keeps the source's up as up instead of taking it (it
// rolled 04 by 11 degrees). The line itself lands where the target's lies.
TEST(Umeyama, ANearlyStraightLineKeepsTheSourcesUp) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.03);
  const Eigen::Matrix3d r(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()));
  std::vector<Eigen::Vector3d> src, dst;
  for (int i = 0; i < 200; ++i) {
    src.emplace_back(2.0 * i, 0.002 * i, 0.0);
    dst.push_back(r * src.back() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  const Similarity s = umeyama(src, dst, {}, false);
  const double tilt = std::acos(std::clamp((s.rotation * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0));
  EXPECT_LT(tilt, 1e-3);  // radians
  EXPECT_LT((s.rotation * Eigen::Vector3d::UnitX() - r * Eigen::Vector3d::UnitX()).norm(), 1e-3);
}

// The body axes from the motion: KITTI's poses (a camera, relabelled z up) move along their +y,
// MulRan's (a LiDAR facing back) along their -x; a standing drive keeps x, y, z.
TEST(BodyAxes, FoundFromTheMotion) {
  const auto drive = [](double yaw) {
    Trajectory t;
    for (int i = 0; i < 50; ++i) {
      Pose p;
      p.stamp = 0.1 * i;
      p.position = Eigen::Vector3d(1.0 * i, 0.02 * std::sin(0.3 * i), 0.0);
      p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
      t.push_back(p);
    }
    return t;
  };
  const BodyAxes kitti = bodyAxes(drive(-M_PI / 2));  // the body's +y along the world's +x
  EXPECT_LT((kitti.ahead - Eigen::Vector3d::UnitY()).norm(), 0.01);
  EXPECT_LT((kitti.up - Eigen::Vector3d::UnitZ()).norm(), 1e-9);
  EXPECT_LT((kitti.left + Eigen::Vector3d::UnitX()).norm(), 0.01);
  const BodyAxes mulran = bodyAxes(drive(M_PI));
  EXPECT_LT((mulran.ahead + Eigen::Vector3d::UnitX()).norm(), 0.01);
  Trajectory still = drive(0.3);
  for (auto& p : still) p.position.setZero();
  EXPECT_EQ(bodyAxes(still).ahead, Eigen::Vector3d::UnitX());
}

TEST(Umeyama, TooFewOrCoincidentPointsAreAnError) {
  EXPECT_THROW(umeyama({{0, 0, 0}, {1, 0, 0}}, {{0, 0, 0}, {1, 0, 0}}, {}, false), Error);
  EXPECT_THROW(
      umeyama({{1, 1, 1}, {1, 1, 1}, {1, 1, 1}}, {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {}, false),
      Error);
}

}  // namespace
}  // namespace flexcloud
