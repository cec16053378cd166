#include <gtest/gtest.h>

#include "flexcloud/params.h"
#include "flexcloud/sheet/control_points.h"

namespace flexcloud {
namespace {

/// 1 m/s along x for 100 s, standing still from t=40 to t=70 (poses every 0.1 s).
struct Drive {
  Trajectory poses;
  std::vector<std::optional<GnssPoint>> gnss;
};

Drive standstillDrive() {
  Drive d;
  for (int k = 0; k <= 1000; ++k) {
    const double t = 0.1 * k;
    const double x = t < 40 ? t : (t < 70 ? 40.0 : t - 30.0);
    Pose p;
    p.stamp = t;
    p.position = Eigen::Vector3d(x, 0.0, 0.0);
    d.poses.push_back(p);
    GnssPoint g;
    g.stamp = t;
    g.position = p.position + Eigen::Vector3d(0.0, 1.0, 0.0);
    g.std_dev.setConstant(0.01);
    d.gnss.emplace_back(g);
  }
  return d;
}

TEST(ControlPoints, EvenlySpreadByArcLengthDespiteAStandstill) {
  const Drive d = standstillDrive();  // 70 m of path
  Params p;
  p.control_points = 8;  // one every 10 m
  const auto sel = selectControlPoints(d.poses, d.gnss, controlPointOptions(p));
  ASSERT_EQ(sel.points.size(), 8u);
  for (std::size_t i = 0; i < sel.points.size(); ++i) {
    EXPECT_NEAR(sel.points[i].source.x(), 10.0 * static_cast<double>(i), 0.051);
  }
  int in_stop = 0;
  for (const auto& cp : sel.points) in_stop += (cp.stamp > 40.05 && cp.stamp < 69.95) ? 1 : 0;
  EXPECT_EQ(in_stop, 0);
  EXPECT_EQ(sel.replaced, 0u);
  EXPECT_EQ(sel.skipped, 0u);
}

TEST(ControlPoints, BadGnssIsReplacedByTheNearestGoodPoseInItsStretch) {
  Drive d = standstillDrive();
  Params p;
  p.control_points = 8;
  p.stddev_threshold = 0.1;
  for (auto& g : d.gnss) {
    if (g->position.x() > 17.05 && g->position.x() < 23.45) g->std_dev.setConstant(1.0);
  }
  const auto sel = selectControlPoints(d.poses, d.gnss, controlPointOptions(p));
  ASSERT_EQ(sel.points.size(), 8u);
  EXPECT_EQ(sel.replaced, 1u);
  EXPECT_NEAR(sel.points[2].source.x(), 17.0, 0.051);  // 3 m from the target, 23.5 is 3.5 m
  for (const auto& cp : sel.points) EXPECT_LE(cp.std_dev, 0.1);
}

TEST(ControlPoints, WholeStretchUnusableIsSkippedAndCounted) {
  Drive d = standstillDrive();
  Params p;
  p.control_points = 8;
  p.excluded_ranges = {{13.0, 27.0}};  // x in [13, 27]: the whole stretch of the 20 m target
  const auto sel = selectControlPoints(d.poses, d.gnss, controlPointOptions(p));
  EXPECT_EQ(sel.skipped, 1u);
  EXPECT_EQ(sel.points.size(), 7u);
  for (const auto& cp : sel.points) EXPECT_FALSE(cp.stamp >= 13.0 && cp.stamp <= 27.0);
}

TEST(ControlPoints, MoreAskedThanPosesGivesEachPoseOnce) {
  Drive d = standstillDrive();
  d.poses.resize(11);
  d.gnss.resize(11);
  Params p;
  p.control_points = 1000;
  const auto sel = selectControlPoints(d.poses, d.gnss, controlPointOptions(p));
  EXPECT_EQ(sel.points.size(), 11u);
  // Every target is accounted for: taken, the same pose as a neighbour's, or no pose in reach.
  EXPECT_EQ(sel.points.size() + sel.merged + sel.skipped, 1000u);
}

TEST(ControlPoints, RefinementPicksTheWorstPosePerStretch) {
  const Drive d = standstillDrive();
  Params p;
  p.control_points = 4;
  auto sel = selectControlPoints(d.poses, d.gnss, controlPointOptions(p));
  std::vector<double> dev(d.poses.size(), 0.0);
  dev[50] = 0.3;   // x = 5, first stretch
  dev[60] = 0.5;   // same stretch, worse
  dev[900] = 0.4;  // last stretch
  std::vector<double> arc;
  for (const auto& pose : d.poses) arc.push_back(pose.position.x());  // monotonic here
  dev[5] = 0.9;    // x = 0.5: too close to the control point at x = 0
  dev[450] = 0.8;  // x = 40, in the standstill, far enough from both neighbours
  dev[760] = 0.7;  // x = 46: 0.7 m from the control point at 46.7, too close
  const auto picks = pickRefinements(sel, dev, arc, 2.0, 5, 1e-3);
  ASSERT_EQ(picks.size(), 3u);
  EXPECT_EQ(picks[0], 450u);
  EXPECT_EQ(picks[1], 60u);
  EXPECT_EQ(picks[2], 900u);
  addControlPoints(sel, picks, d.poses, d.gnss);
  EXPECT_EQ(sel.points.size(), 7u);
  for (std::size_t i = 1; i < sel.points.size(); ++i) {
    EXPECT_LT(sel.points[i - 1].pose_index, sel.points[i].pose_index);
  }
}

}  // namespace
}  // namespace flexcloud
