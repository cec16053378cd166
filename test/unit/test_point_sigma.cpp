// The map points' sigmas: the nearest pose found through the grid against a search of every
// pose, the sigma against its formula, and the widened rows against the points they copy.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/params.h"
#include "flexcloud/uncertainty/point_sigma.h"
#include "test_util.h"

namespace flexcloud {
namespace {

/// A sheet over the box [-500, 1000]^2 x [-100, 100] that moves every point by `scale` about the
/// origin (1: not at all).
std::shared_ptr<RubberSheet> scalingSheet(double scale) {
  return test::scalingSheet({-500.0, -500.0, -100.0}, {1000.0, 1000.0, 100.0}, {10.0, 20.0, 1.0},
                            scale);
}

/// A winding drive of n poses 1 m apart, with sigmas growing along it.
Trajectory windingDrive(std::size_t n, PoseSigmas& sigmas) {
  Trajectory t(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double s = static_cast<double>(i);
    t[i].stamp = 0.1 * s;
    t[i].position = {s, 40.0 * std::sin(s / 60.0), 0.01 * s};
    sigmas.h.push_back(0.01 + 0.001 * s);
    sigmas.v.push_back(0.02 + 0.002 * s);
  }
  return t;
}

// Within 100 m of the drive's box, the pose the grid names is within a cell's diagonal (1.5 m
// here) of the nearest in the plan; beyond it (the border cell's pose), within 10 % of its
// distance.
TEST(PointSigma, TheGridNamesTheNearestPose) {
  PoseSigmas sigmas;
  const Trajectory t = windingDrive(500, sigmas);
  const PointSigmaField field(t, sigmas, *scalingSheet(1.0));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> x(-300.0, 800.0), y(-300.0, 300.0);
  for (int k = 0; k < 2000; ++k) {
    const Eigen::Vector3d p(x(rng), y(rng), 5.0);
    double best = 1e300;
    for (const Pose& q : t) best = std::min(best, (q.position - p).head<2>().norm());
    const double named = (t[field.nearestPose(p)].position - p).head<2>().norm();
    const bool inside = std::abs(p.y()) < 140.0 && p.x() > -100.0 && p.x() < 599.0;
    EXPECT_LE(named, inside ? best + 1.5 : 1.1 * best) << p.transpose();
  }
}

// A point 30 m left of pose 100 (at x = 201 m) and 4 m above it: its pose's sigma, the scatter, the
// heading error times 30 m and the tilt times 4 m horizontally; the tilt times 30 m vertically.
// Where the sheet stretches the map by 1 %, twice the strain squared times the squares of the
// distance and of 5 m, both ways.
TEST(PointSigma, APointsSigmaGrowsWithItsDistanceFromThePose) {
  PoseSigmas sigmas;
  Trajectory t = windingDrive(500, sigmas);
  for (std::size_t i = 0; i < t.size(); ++i) {  // on the centres of the grid's 2 m cells
    t[i].position = {2.0 * static_cast<double>(i) + 1.0, 0.0, 0.0};
  }
  PointSigmaModel m;
  m.scatter_h = 0.02, m.scatter_v = 0.03, m.heading = 0.001, m.tilt = 0.002;
  const auto rigid = scalingSheet(1.0);
  const PointSigmaField field(t, sigmas, *rigid, m);
  const Eigen::Vector3d p(201.0, 30.0, 4.0);
  const int tet = rigid->locate(p).tet;
  ASSERT_GE(tet, 0);
  EXPECT_NEAR(field.strain(tet).ratio, 0.0, 1e-6);
  const PointSigma s = field.at(p, tet);
  const double h2 = 0.11 * 0.11 + 0.02 * 0.02 + 0.03 * 0.03 + 0.008 * 0.008;
  const double v2 = 0.22 * 0.22 + 0.03 * 0.03 + 0.06 * 0.06;
  EXPECT_NEAR(s.h, std::sqrt(h2), 1e-6);
  EXPECT_NEAR(s.v, std::sqrt(v2), 1e-6);
  const auto stretching = scalingSheet(1.01);
  const PointSigmaField stretched(t, sigmas, *stretching, m);
  const int in = stretching->locate(p).tet;
  EXPECT_NEAR(stretched.strain(in).ratio, 0.01, 1e-6);
  const double bent2 = 2 * 0.01 * 0.01 * (30.0 * 30.0 + 4.0 * 4.0 + 5.0 * 5.0);
  EXPECT_NEAR(stretched.at(p, in).h, std::sqrt(h2 + bent2), 1e-6);
  EXPECT_NEAR(stretched.at(p, in).v, std::sqrt(v2 + bent2), 1e-6);
  EXPECT_NEAR(stretched.at(p, -1).h, std::sqrt(h2 + bent2), 1e-6);  // beyond the hull
  // The parameters in their units: m and mrad.
  Params params;
  params.point_scatter = 0.02, params.point_heading_sigma = 1.0, params.point_tilt_sigma = 2.0;
  const PointSigmaField from_params(t, sigmas, *rigid, pointSigmaModel(params));
  EXPECT_NEAR(from_params.at(p, tet).h, s.h, 1e-6);
  // A place however far from the poses (a stray point of a map) takes the border cell's pose
  // and a sigma that is large and a number.
  for (const double far : {1e6, -1e12, 1e30}) {
    const PointSigma at_far = field.at({far, far, 0.0}, -1);
    EXPECT_TRUE(std::isfinite(at_far.h) && std::isfinite(at_far.v)) << far;
    EXPECT_GT(at_far.h, s.h) << far;
    EXPECT_LT(field.nearestPose({far, far, 0.0}), t.size());
  }
  // Without the poses' sigmas every point's sigma is infinite: nothing is known.
  EXPECT_TRUE(std::isinf(PointSigmaField(t, PoseSigmas{}, *rigid).at({1, 2, 3}, tet).h));
}

// A point moved with its own pose (a rebuilt map) takes that pose's sigma and its distance
// from that pose, whichever pose is nearest in the plan: 30 m left of pose 100 as above, and
// the same place seen from pose 110, 20 m back along the road; naming no pose, its cell's.
TEST(PointSigma, APointMovedWithItsOwnPoseTakesThatPosesSigma) {
  PoseSigmas sigmas;
  Trajectory t = windingDrive(500, sigmas);
  for (std::size_t i = 0; i < t.size(); ++i) t[i].position = {2.0 * i + 1.0, 0.0, 0.0};
  PointSigmaModel m;
  m.scatter_h = 0.02, m.scatter_v = 0.03, m.heading = 0.001, m.tilt = 0.002;
  const auto rigid = scalingSheet(1.0);
  const PointSigmaField field(t, sigmas, *rigid, m);
  const Eigen::Vector3d p(201.0, 30.0, 4.0);
  const PointSigma own = field.ofPose(p, 100);
  EXPECT_NEAR(own.h, field.at(p, rigid->locate(p).tet).h, 1e-6);
  EXPECT_NEAR(own.v, field.at(p, rigid->locate(p).tet).v, 1e-6);
  const PointSigma seen = field.ofPose(p, 110);
  const double d2 = 20.0 * 20.0 + 30.0 * 30.0;
  EXPECT_NEAR(seen.h, std::sqrt(0.12 * 0.12 + 0.02 * 0.02 + 1e-6 * d2 + 0.008 * 0.008), 1e-6);
  EXPECT_NEAR(seen.v, std::sqrt(0.24 * 0.24 + 0.03 * 0.03 + 4e-6 * d2), 1e-6);
  for (const int none : {PointSigmaField::kNoPose, 500, 100000}) {
    EXPECT_NEAR(field.ofPose(p, none).h, own.h, 1e-6) << none;
  }
}

// Two control points 10 cm apart in the map and 2 m apart in the result (a map torn between
// two passes): the tetrahedra on that edge stretch more than 19 times, yet the points in them
// may lie only about its 1.9 m change from their place, and their sigma says so.
TEST(PointSigma, ATornEdgeAddsItsChangeNotItsRatioTimesTheDistance) {
  std::vector<Eigen::Vector3d> src, dst;
  for (double x : {-500.0, 1000.0})
    for (double y : {-500.0, 1000.0})
      for (double z : {-100.0, 100.0}) src.emplace_back(x, y, z);
  dst = src;
  src.emplace_back(10.0, 20.0, 1.0);
  dst.emplace_back(10.0, 20.0, 1.0);
  src.emplace_back(10.1, 20.0, 1.0);
  dst.emplace_back(12.0, 20.0, 1.0);
  Affine34 identity = Affine34::Zero();
  identity.leftCols<3>().setIdentity();
  const RubberSheet sheet(src, dst, identity);
  PoseSigmas sigmas;
  const Trajectory t = windingDrive(500, sigmas);
  const PointSigmaField field(t, sigmas, sheet);
  int torn = 0;
  for (std::size_t k = 0; k < sheet.numTetrahedra(); ++k) {
    const auto& v = sheet.tetrahedra()[k];
    if (std::count(v.begin(), v.end(), 8) + std::count(v.begin(), v.end(), 9) < 2) continue;
    ++torn;
    const TetStrain& s = field.strain(static_cast<int>(k));
    EXPECT_GE(s.ratio, 19.0 - 1e-6);
    EXPECT_NEAR(s.change, 1.9, 1e-6);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int i : v) centre += 0.25 * sheet.sources()[static_cast<std::size_t>(i)];
    const PointSigma free = PointSigmaField(t, sigmas, *scalingSheet(1.0)).at(centre, -1);
    const PointSigma capped = field.at(centre, static_cast<int>(k));
    EXPECT_NEAR(capped.h * capped.h, free.h * free.h + 1.9 * 1.9, 1e-4);
  }
  EXPECT_GT(torn, 0);
}

// The warp gives each point the sigma of its warped place and tetrahedron, NaN for a NaN
// point; each widened row holds the point's bytes unchanged, then sigma_h and sigma_v.
TEST(PointSigma, TheWarpGivesEachPointItsSigmaAndTheRowsKeepItsBytes) {
  PoseSigmas sigmas;
  const Trajectory t = windingDrive(100, sigmas);
  const auto sheet = scalingSheet(1.02);
  const PointSigmaField field(t, sigmas, *sheet);
  const std::size_t step = 20, n = 100000;  // x, y, z float, then an 8-byte field
  std::vector<std::uint8_t> in(n * step);
  for (std::size_t i = 0; i < in.size(); ++i) in[i] = static_cast<std::uint8_t>(i * 7);
  XyzLayout l;
  l.offset[0] = 0, l.offset[1] = 4, l.offset[2] = 8;
  l.point_step = step, l.points = n;
  for (std::size_t i = 0; i < n; ++i) {
    const double u = static_cast<double>(i);
    l.set(in.data() + i * step, {u * 0.001, 3.0 + (i % 40), i == 7 ? std::nan("") : 1.0});
  }
  std::vector<std::uint8_t> warped = in;
  std::vector<float> sig(2 * n);
  warpPoints(warped.data(), l, *sheet, 2, "map", neverCancelled(),
             {&field, reinterpret_cast<std::uint8_t*>(sig.data())});
  for (std::size_t i = 0; i < n; ++i) {
    const float h = sig[2 * i], v = sig[2 * i + 1];
    if (i == 7) {
      EXPECT_TRUE(std::isnan(h) && std::isnan(v));
      continue;
    }
    const Eigen::Vector3d p = l.get(in.data() + i * step);
    const PointSigma s = field.at(sheet->transform(p), sheet->locate(p).tet);
    ASSERT_NEAR(h, s.h, 1e-6) << i;
    ASSERT_NEAR(v, s.v, 1e-6) << i;
    EXPECT_GT(h, 0.02F);
  }
  // The node's and the tool's way: the rows widened first (room for the sigmas, NaN), the
  // sigmas written into them by the warp: each row the point's warped bytes, then its sigmas.
  const std::size_t wide_step = step + kPointSigmaBytes;
  std::vector<std::uint8_t> rows(n * wide_step, 0);
  widenPoints(in.data(), step, n, rows.data());
  float room[2];
  std::memcpy(room, rows.data() + step, sizeof(room));
  EXPECT_TRUE(std::isnan(room[0]) && std::isnan(room[1]));
  XyzLayout wide = l;
  wide.point_step = wide_step;
  warpPoints(rows.data(), wide, *sheet, 2, "map", neverCancelled(),
             {&field, rows.data() + step, wide_step});
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* row = rows.data() + i * wide_step;
    ASSERT_EQ(std::memcmp(row, warped.data() + i * step, step), 0) << i;
    ASSERT_EQ(std::memcmp(row + step, &sig[2 * i], kPointSigmaBytes), 0) << i;
  }
  const auto fields = withSigmaFields({pointField("x", 0, 7)}, step, "map.pcd");
  ASSERT_EQ(fields.size(), 3u);
  EXPECT_EQ(fields[1].name, "sigma_h");
  EXPECT_EQ(fields[1].offset, step);
  EXPECT_EQ(fields[2].offset, step + 4);
  try {
    withSigmaFields(fields, step + 8, "out/map_georeferenced.pcd");
    ADD_FAILURE() << "a map with sigma fields took them again";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "out/map_georeferenced.pcd: already holds a field sigma_h (georeferenced "
                 "before?); point_sigma would write it again");
  }
}

}  // namespace
}  // namespace flexcloud
