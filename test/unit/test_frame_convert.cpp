// Conversions between the map frame, ENU and WGS84 through a result (the node's ~to_ll,
// ~from_ll, ~to_enu) and the projectors of the exported maps.
#include <gtest/gtest.h>

#include <GeographicLib/UTMUPS.hpp>
#include <set>

#include "../common/test_util.h"
#include "flexcloud/geo/frame_convert.h"
#include "flexcloud/geo/projection.h"
#include "flexcloud/sim/drive_simulator.h"

namespace flexcloud {
namespace {

const GeoreferenceResult& result() {
  static const GeoreferenceResult r = [] {
    sim::SimParams sp;
    sp.seed = 5;
    sp.map_points = 1000;
    const sim::SimDrive d = sim::simulateDrive(sp);
    return georeference(test::inputOf(d), test::atSimDatum(d));
  }();
  return r;
}

TEST(FrameConvert, MapPointsRoundTripThroughTheSheetWithin1um) {
  const auto& r = result();
  double worst = 0.0;
  for (std::size_t i = 0; i < r.poses.size(); i += 97) {
    // On the trajectory, 20 m beside it and 8 m above it: inside tetrahedra of every kind.
    for (const Eigen::Vector3d& off :
         {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 20, 0), Eigen::Vector3d(-20, 0, 8)}) {
      const Eigen::Vector3d p = r.poses[i].position + off;
      const Eigen::Vector3d back = enuToMap(r, mapToEnu(r, p));
      worst = std::max(worst, (back - p).norm());
    }
  }
  EXPECT_LT(worst, 1e-6);
  // Far beyond the cuboid the outside transform applies, and is inverted too.
  const Eigen::Vector3d far(1e5, -2e5, 30.0);
  EXPECT_LT((enuToMap(r, mapToEnu(r, far)) - far).norm(), 1e-6);
}

TEST(FrameConvert, PosesTakeTheCorrectedTrajectorysPlace) {
  const auto& r = result();
  std::set<std::size_t> vertices;  // a control point's pose: its place is each tetrahedron's
  for (const auto& cp : r.control_points.points) vertices.insert(cp.pose_index);
  for (std::size_t i = 0; i < r.poses.size(); i += 211) {
    if (vertices.count(i) != 0) continue;
    const Pose e = mapPoseToEnu(r, r.poses[i]);
    EXPECT_LT((e.position - r.rubbersheet[i].position).norm(), 1e-9);
    // The sheet's rotation around the pose (to_enu), against the fused trajectory's orientation
    // the corrected trajectory takes (the sheet was fitted to it): within 0.06 degrees.
    EXPECT_LT(e.orientation.angularDistance(r.rubbersheet[i].orientation), 1e-3);
  }
}

TEST(FrameConvert, GeodeticRoundTripAndBadInput) {
  const auto& r = result();
  const Eigen::Vector3d enu(-812.25, 433.5, 2.0);
  const Datum g = enuToGeodetic(r, enu);
  EXPECT_LT((geodeticToEnu(r, g) - enu).norm(), 1e-8);
  EXPECT_NE(test::errorOf([&] {
              geodeticToEnu(r, {91.0, 0.0, 0.0});
            }).find("not a valid"),
            std::string::npos);
  GeoreferenceResult none;
  EXPECT_NE(test::errorOf([&] { mapToEnu(none, enu); }).find("no georeferencing result"),
            std::string::npos);
}

TEST(Projection, UtmAgreesWithGeographicLibAndMgrsStaysInItsSquare) {
  const Datum datum{48.262, 11.667, 480.0};
  const MapProjection utm(datum, ProjectorType::kLocalCartesianUtm);
  EXPECT_EQ(utm.zone().epsg(), 32632);
  // The datum itself: UTM origin, at its ellipsoidal height (Autoware's z), so (0, 0, 480).
  const Eigen::Vector3d origin = utm.fromEnu(Eigen::Vector3d::Zero());
  EXPECT_LT((origin - Eigen::Vector3d(0.0, 0.0, 480.0)).norm(), 1e-6);
  // The local Cartesian frame is ENU with z the ellipsoidal height.
  const MapProjection local(datum, ProjectorType::kLocalCartesian);
  EXPECT_LT((local.fromEnu({12.5, -3.0, 2.0}) - Eigen::Vector3d(12.5, -3.0, 482.0)).norm(), 1e-9);
  // 1 km east in ENU is not 1 km east in UTM: the grid turns by the meridian convergence
  // (1.99 degrees here by PROJ, east of the central meridian 9 E): 35 m north at 1 km.
  const Eigen::Vector3d east = utm.fromEnu({1000.0, 0.0, 0.0}) - origin;
  EXPECT_NEAR(std::atan2(east.y(), east.x()) * 180.0 / M_PI, 1.99, 0.01);
  // Its length: 1 km at 480 m above the ellipsoid is 999.925 m on it (R / (R + h)), times the
  // UTM point scale 1.0000814 there (PROJ's factors for EPSG:32632 at the datum).
  EXPECT_NEAR(east.norm(), 1000.0 * 6381000.0 / 6381480.0 * 1.0000814, 0.003);

  const MapProjection mgrs(datum, ProjectorType::kMgrs);
  EXPECT_EQ(mgrs.mgrsGrid().substr(0, 3), "32U");
  const Eigen::Vector3d in = mgrs.fromEnu({10.0, 10.0, 0.0});
  EXPECT_GE(in.x(), 0.0);
  EXPECT_LT(in.x(), 1e5);
  EXPECT_NE(test::errorOf([&] {
              mgrs.fromEnu({150000.0, 0.0, 0.0});
            }).find("leaves the MGRS"),
            std::string::npos);
  EXPECT_NE(test::errorOf([&] {
              utmZoneOf({84.5, 11.0, 0.0});
            }).find("80 S to 84 N"),
            std::string::npos);
  EXPECT_NE(test::errorOf([] { parseProjector("utm"); }).find("'utm'"), std::string::npos);
}

}  // namespace
}  // namespace flexcloud
