// Error-driven refinement of the control points against measured fixes
// (src/core/sheet/sheet_builder.h): it follows where the sheet and the fixes part, not a lone
// fix off its neighbours.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "flexcloud/params.h"
#include "sheet/sheet_builder.h"

namespace flexcloud {
namespace {

constexpr std::size_t kPoses = 301;
constexpr std::size_t kSpike = 190;                  // this fix is 1 m off its neighbours
constexpr std::size_t kBumpFrom = 60, kBumpTo = 76;  // the fixes here part from the SLAM

struct Drive {
  Trajectory slam;
  std::vector<std::optional<GnssPoint>> fixes;
};

/// 600 m on an arc of 200 m radius, a pose every 2 m, gently up and down. The fixes lie where
/// the SLAM is plus a smooth drift of a few decimetres, a bump of 0.6 m over 30 m (a stretch the
/// SLAM got wrong) and, at one pose, a spike of 1 m.
Drive arcDrive() {
  Drive d;
  for (std::size_t i = 0; i < kPoses; ++i) {
    const double s = 2.0 * static_cast<double>(i);
    Pose p;
    p.stamp = 0.2 * static_cast<double>(i);
    p.position = Eigen::Vector3d(200.0 * std::sin(s / 200.0), 200.0 * (1.0 - std::cos(s / 200.0)),
                                 2.0 * std::sin(s / 90.0));
    d.slam.push_back(p);
    Eigen::Vector3d off(0.3 * std::sin(s / 100.0), 0.2 * std::cos(s / 80.0),
                        0.1 * std::sin(s / 60.0));
    if (i >= kBumpFrom && i < kBumpTo) {
      off.x() += 0.6 * std::sin(M_PI * static_cast<double>(i - kBumpFrom) / (kBumpTo - kBumpFrom));
    }
    if (i == kSpike) off.y() += 1.0;
    GnssPoint g;
    g.stamp = p.stamp;
    g.position = p.position + off;
    g.std_dev.setConstant(0.01);
    d.fixes.emplace_back(g);
  }
  return d;
}

ControlPointSelection choose(const Drive& d, bool targets_are_fixes) {
  Params p;
  p.control_points = 20;  // 5 spread evenly, 15 by refinement
  p.refine_fraction = 0.75;
  SheetOptions o = sheetOptions(p);
  o.targets_are_fixes = targets_are_fixes;
  const Cuboid cuboid = makeCuboid(d.slam, d.fixes, o);
  const std::vector<bool> usable(d.slam.size(), true);
  return chooseControlPoints(d.slam, d.fixes, usable, Eigen::Isometry3d::Identity(), cuboid, o);
}

bool hasPose(const ControlPointSelection& s, std::size_t pose) {
  return std::any_of(s.points.begin(), s.points.end(),
                     [&](const ControlPoint& c) { return c.pose_index == pose; });
}

std::size_t countIn(const ControlPointSelection& s, std::size_t from, std::size_t to) {
  return static_cast<std::size_t>(std::count_if(s.points.begin(), s.points.end(), [&](auto& c) {
    return c.pose_index >= from && c.pose_index < to;
  }));
}

TEST(Refinement, AgainstFixesALoneFixOffItsNeighboursDrawsNoControlPoint) {
  const Drive d = arcDrive();
  const ControlPointSelection fixes = choose(d, true);
  EXPECT_EQ(fixes.points.size(), 20u);
  EXPECT_FALSE(hasPose(fixes, kSpike));
  EXPECT_EQ(countIn(fixes, kSpike - 1, kSpike + 2), 0u);
  // The stretch where the fixes part from the SLAM gets control points of its own.
  EXPECT_GE(countIn(fixes, kBumpFrom, kBumpTo), 2u);

  // Against the fused trajectory (smooth, no spikes to fear) every deviation counts: the spike
  // is the worst pose and draws the first refinement.
  const ControlPointSelection fused = choose(d, false);
  EXPECT_TRUE(hasPose(fused, kSpike));
  EXPECT_GE(countIn(fused, kBumpFrom, kBumpTo), 2u);
}

}  // namespace
}  // namespace flexcloud
