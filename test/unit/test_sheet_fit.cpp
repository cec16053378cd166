// The sheet fitted to the whole fused trajectory (src/core/sheet/sheet_fit.h), on a straight 200 m
// drive with a control point every 50 m and points beside each, as the product places them.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "sheet/sheet_fit.h"

namespace flexcloud {
namespace {

using Vec3 = Eigen::Vector3d;
using Correction = std::function<Vec3(const Vec3&)>;

struct Drive {
  Trajectory slam, fused;
  ControlPointSelection cps;
  std::vector<PointPair> beside;
  std::vector<Vec3> corners;
};

/// Poses every 2 m along x; control points every 25 poses, each with points 25 m left and
/// right (6 m down) and 10 m up, targets moved by `at_cp`; the fused poses moved by `fused`.
Drive straightDrive(const Correction& at_cp, const Correction& fused) {
  Drive d;
  for (int i = 0; i <= 100; ++i) {
    Pose p;
    p.stamp = i;
    p.position = Vec3(2.0 * i, 0, 0);
    d.slam.push_back(p);
    p.position += fused(p.position);
    d.fused.push_back(p);
  }
  for (std::size_t i = 0; i <= 100; i += 25) {
    ControlPoint c;
    c.pose_index = i;
    c.source = d.slam[i].position;
    c.target = c.source + at_cp(c.source);
    d.cps.points.push_back(c);
    for (const Vec3& off : {Vec3(0, 25, -6), Vec3(0, -25, -6), Vec3(0, 0, 10)}) {
      PointPair b;
      b.source = c.source + off;
      b.target = b.source + at_cp(c.source);
      b.pose_index = i;
      d.beside.push_back(b);
    }
  }
  for (int c = 0; c < 8; ++c) {
    d.corners.emplace_back((c & 1) ? 1200.0 : -1000.0, (c & 2) ? 1000.0 : -1000.0,
                           (c & 4) ? 1000.0 : -1000.0);
  }
  return d;
}

/// The sheet through the drive's pairs (control points, beside, corners: the order
/// buildSheet() gives), the corners moved by `corner_move`, and every target moved by `move`.
std::shared_ptr<RubberSheet> sheetOf(const Drive& d, const Correction& corner_move,
                                     const std::vector<Vec3>& move = {}) {
  std::vector<Vec3> src, dst;
  for (std::size_t k = 0; k < d.cps.points.size(); ++k) {
    src.push_back(d.cps.points[k].source);
    dst.push_back(d.cps.points[k].target + (move.empty() ? Vec3::Zero() : move[k]));
  }
  for (const auto& b : d.beside) {
    src.push_back(b.source);
    dst.push_back(b.target + (move.empty() ? Vec3::Zero() : move[b.pose_index / 25]));
  }
  for (const auto& c : d.corners) {
    src.push_back(c);
    dst.push_back(c + corner_move(c));
  }
  return std::make_shared<RubberSheet>(src, dst, Affine34::Identity());
}

/// Sum of squared distances of the sheet's images of the SLAM poses from the fused poses.
/// The fit's cost: every pose's squared distance from its fused pose, a control point's own
/// pose weighing as much as ten others (its squared distance a hundredfold).
double cost(const RubberSheet& sheet, const Drive& d) {
  std::vector<double> weight(d.slam.size(), 1.0);
  for (const auto& cp : d.cps.points) weight[cp.pose_index] = 10.0;
  double s = 0.0;
  for (std::size_t i = 0; i < d.slam.size(); ++i) {
    const double e = (sheet.transform(d.slam[i].position) - d.fused[i].position).norm();
    s += weight[i] * weight[i] * e * e;
  }
  return s;
}

TEST(SheetFit, NothingToFitWhereTheSheetHoldsTheCorrection) {
  // An affine correction everywhere (the corners too): the sheet through the control points is
  // already exact at every pose.
  const Correction affine = [](const Vec3& p) { return Vec3(0.01 * p.x(), 0.5, 0.002 * p.x()); };
  const Drive d = straightDrive(affine, affine);
  const auto sheet = sheetOf(d, affine);
  ASSERT_LT(cost(*sheet, d), 1e-18);
  const std::vector<Vec3> move = fitSheetTargets(*sheet, d.cps, d.beside, d.slam, d.fused);
  ASSERT_EQ(move.size(), 5u);
  for (const Vec3& m : move) EXPECT_LT(m.norm(), 1e-9) << m.transpose();
}

TEST(SheetFit, BumpsBetweenControlPointsAreFittedInTheLeastSquaresSense) {
  // The fused poses bulge 0.2 m sideways between control points, nothing at them: the sheet
  // through the control points misses the bulge entirely; the fitted one moves every control
  // point (and its points beside) sideways toward the bulge's mean of 0.1 m, held at its own
  // pose by that pose's weight: a few centimetres.
  const Correction none = [](const Vec3&) { return Vec3::Zero(); };
  const Correction bump = [](const Vec3& p) {
    const double s = std::sin(3.14159265358979 * p.x() / 50.0);
    return Vec3(0, 0.2 * s * s, 0);
  };
  const Drive d = straightDrive(none, bump);
  const auto through = sheetOf(d, none);
  const std::vector<Vec3> move = fitSheetTargets(*through, d.cps, d.beside, d.slam, d.fused);
  for (const Vec3& m : move) {
    EXPECT_GT(m.y(), 0.005) << m.transpose();
    EXPECT_LT(m.y(), 0.05) << m.transpose();
    EXPECT_LT(std::abs(m.x()) + std::abs(m.z()), 0.01) << m.transpose();
  }
  const auto fitted = sheetOf(d, none, move);
  const double before = cost(*through, d), after = cost(*fitted, d);
  EXPECT_LT(after, 0.9 * before) << before << " -> " << after;  // 1.50 -> 1.32
  // A least-squares optimum (up to the small ridge): moving any control point by 1 cm along
  // any axis costs more.
  for (std::size_t k = 0; k < move.size(); ++k) {
    for (int axis = 0; axis < 3; ++axis) {
      for (const double step : {-0.01, 0.01}) {
        std::vector<Vec3> other = move;
        other[k](axis) += step;
        EXPECT_GT(cost(*sheetOf(d, none, other), d), after) << k << " " << axis << " " << step;
      }
    }
  }
}

}  // namespace
}  // namespace flexcloud
