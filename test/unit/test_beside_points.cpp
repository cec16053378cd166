// The points beside and above the control points (flexcloud/sheet/beside_points.h) lie across
// the road and above it whichever body axis the SLAM drives along, and move with the fused pose.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "flexcloud/sheet/beside_points.h"

namespace flexcloud {
namespace {

using Vec3 = Eigen::Vector3d;

/// A straight 400 m drive along world x, a pose every metre, with the body frame turned by
/// `body_to_world`; control points every 50 m.
struct Drive {
  Trajectory slam;
  ControlPointSelection cps;
};
Drive straightDrive(const Eigen::Quaterniond& body_to_world) {
  Drive d;
  for (int i = 0; i <= 400; ++i) {
    Pose p;
    p.stamp = i;
    p.position = Vec3(i, 0, 0);
    p.orientation = body_to_world;
    d.slam.push_back(p);
  }
  for (std::size_t i = 0; i <= 400; i += 50) {
    ControlPoint c;
    c.pose_index = i;
    c.source = d.slam[i].position;
    c.target = c.source;
    d.cps.points.push_back(c);
  }
  return d;
}

Eigen::Quaterniond turn(double angle, const Vec3& axis) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis));
}

void expectAcrossAndAbove(const Drive& d, const std::vector<PointPair>& pairs) {
  // Per control point: one above, and on each side one at 25 m and one at 50 m, staggered up
  // and down by a quarter of 25 m, the outer one opposite the inner.
  ASSERT_EQ(pairs.size(), 5 * d.cps.points.size());
  int left = 0, right = 0, above = 0, outer = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const Vec3 o = pairs[k].source - d.slam[pairs[k].pose_index].position;
    EXPECT_NEAR(o.x(), 0.0, 1e-9) << "a point ahead of or behind its control point";
    if (std::abs(o.y()) < 1e-9) {
      EXPECT_NEAR(o.z(), 10.0, 1e-9);
      ++above;
      continue;
    }
    EXPECT_NEAR(std::abs(o.z()), 6.25, 1e-9);
    if (std::abs(std::abs(o.y()) - 50.0) < 1e-9) {
      ++outer;
      // Staggered the other way from the inner point on its side.
      const auto inner = std::find_if(pairs.begin(), pairs.end(), [&](const PointPair& p) {
        const Vec3 q = p.source - d.slam[p.pose_index].position;
        return p.pose_index == pairs[k].pose_index && std::abs(q.y() - 0.5 * o.y()) < 1e-9;
      });
      ASSERT_NE(inner, pairs.end());
      EXPECT_NEAR((inner->source - d.slam[inner->pose_index].position).z(), -o.z(), 1e-9);
    } else {
      EXPECT_NEAR(std::abs(o.y()), 25.0, 1e-9);
    }
    (o.y() > 0 ? left : right)++;
  }
  EXPECT_EQ(above, static_cast<int>(d.cps.points.size()));
  EXPECT_EQ(left, 2 * above);
  EXPECT_EQ(right, 2 * above);
  EXPECT_EQ(outer, 2 * above);
}

TEST(BesidePoints, LieAcrossTheRoadWhenTheBodyDrivesAlongX) {
  const Drive d = straightDrive(Eigen::Quaterniond::Identity());
  expectAcrossAndAbove(d, besidePoints(d.cps, d.slam, d.slam, 25.0, 10.0));
}

TEST(BesidePoints, LieAcrossTheRoadWhenTheBodyDrivesAlongY) {
  // As the KITTI odometry of ../shared/data/kitti_lo: body y ahead, z up. Points at body y
  // would lie on the road ahead and behind, where they carry no rotation.
  const Drive d = straightDrive(turn(-M_PI / 2, Vec3::UnitZ()));
  expectAcrossAndAbove(d, besidePoints(d.cps, d.slam, d.slam, 25.0, 10.0));
}

TEST(BesidePoints, LieAcrossTheRoadFromACameraFrame) {
  // A camera's frame: z ahead, x right, y down.
  const Eigen::Matrix3d body_to_world =
      (Eigen::Matrix3d() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished();
  const Drive d = straightDrive(Eigen::Quaterniond(body_to_world));
  expectAcrossAndAbove(d, besidePoints(d.cps, d.slam, d.slam, 25.0, 10.0));
}

TEST(BesidePoints, CarryTheFusedPosesTurn) {
  // The fused poses turned by 1 degree of heading about the SLAM's: a point 25 m to the side
  // moves 25 sin(1 deg) = 0.436 m along the road, the point above not at all.
  const Drive d = straightDrive(turn(-M_PI / 2, Vec3::UnitZ()));
  Trajectory fused = d.slam;
  const Eigen::Quaterniond yaw = turn(M_PI / 180.0, Vec3::UnitZ());
  for (auto& p : fused) p.orientation = yaw * p.orientation;
  for (const auto& b : besidePoints(d.cps, d.slam, fused, 25.0, 10.0)) {
    const Vec3 o = b.source - d.slam[b.pose_index].position;
    const Vec3 moved = b.target - b.source;
    EXPECT_NEAR(moved.x(), -std::sin(M_PI / 180.0) * o.y(), 1e-9);
    EXPECT_NEAR(moved.norm(), 2.0 * std::sin(M_PI / 360.0) * o.head<2>().norm(), 1e-9);
  }
}

}  // namespace
}  // namespace flexcloud
