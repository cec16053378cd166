// On a straight road no fix shows the drive's roll about it: the fusion keeps the tilt the rigid
// start gave it, and does not roll the drive to pass the SLAM's height drift off as the road's
// curve (KITTI 04, a 400 m straight: rolled 11.4 degrees before).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "flexcloud/fusion/fusion.h"
#include "flexcloud/params.h"

namespace flexcloud {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr double kDt = 0.1;          // s between poses and fixes
constexpr double kSpeed = 10.0;      // m/s
constexpr std::size_t kPoses = 400;  // 400 m
constexpr double kLength = kSpeed * kDt * kPoses;

/// The true road: along x, bowed 2 m to the side, level.
Vec3 truthAt(double x) { return Vec3(x, 2.0 * std::sin(M_PI * x / kLength), 0.0); }

/// The SLAM: the road with its height drifted into a 1.5 m bow (in the shape of the road's
/// bow to the side), its body level and along the road.
Trajectory slam() {
  Trajectory out;
  for (std::size_t i = 0; i < kPoses; ++i) {
    const double x = kSpeed * kDt * static_cast<double>(i);
    Pose p;
    p.stamp = 100.0 + kDt * static_cast<double>(i);
    p.position = truthAt(x) + Vec3(0.0, 0.0, 1.5 * std::sin(M_PI * x / kLength));
    const Vec3 ahead = (truthAt(x + 0.5) - truthAt(x - 0.5)).normalized();
    p.orientation = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitX(), ahead);
    out.push_back(p);
  }
  return out;
}

/// RTK fixes at the poses' stamps: the truth with 1 cm of white noise, 2 / 3 cm reported.
std::vector<GnssPoint> fixes() {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 0.01);
  std::vector<GnssPoint> out;
  for (std::size_t i = 0; i < kPoses; ++i) {
    GnssPoint g;
    g.stamp = 100.0 + kDt * static_cast<double>(i);
    g.position = truthAt(kSpeed * kDt * static_cast<double>(i)) + Vec3(n(rng), n(rng), n(rng));
    g.std_dev = Vec3(0.02, 0.02, 0.03);
    out.push_back(g);
  }
  return out;
}

TEST(FusionTilt, AStraightRoadIsNotRolledToFitTheSlamsHeight) {
  Params params;
  params.max_time_offset = 0.0;  // the stamps are right
  const Trajectory poses = slam();
  const FusionResult r =
      fuseTrajectory(poses, fixes(), Eigen::Isometry3d::Identity(), fusionOptions(params));
  ASSERT_EQ(r.poses.size(), poses.size());
  double worst = 0.0;  // degrees: the fused body's up from the vertical
  for (const Pose& p : r.poses) {
    const Vec3 up = p.orientation.normalized() * Vec3::UnitZ();
    worst = std::max(worst, std::acos(std::min(1.0, up.z())) * 180.0 / M_PI);
  }
  std::printf("fused body's up at most %.2f degrees from the vertical\n", worst);
  EXPECT_LT(worst, 2.0);  // 1.25 degrees; without the tilt held, 37.2: the bows' angle
}

}  // namespace
}  // namespace flexcloud
