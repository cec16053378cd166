#include <gtest/gtest.h>

#include "flexcloud/geo/geodesy.h"
#include "flexcloud/types.h"

namespace flexcloud {
namespace {

TEST(Geodesy, DatumIsTheOrigin) {
  const EnuFrame enu({48.262, 11.667, 480.0});
  EXPECT_NEAR(enu.toEnu(48.262, 11.667, 480.0).norm(), 0.0, 1e-9);
}

TEST(Geodesy, KnownDistancesAtTheEquator) {
  const EnuFrame enu({0.0, 0.0, 0.0});
  // WGS84: one degree of latitude at the equator is 110574.3 m of meridian arc; 0.01 deg north
  // lies 1105.74 m north (and drops below the tangent plane by ~0.096 m).
  const Eigen::Vector3d north = enu.toEnu(0.01, 0.0, 0.0);
  EXPECT_NEAR(north.x(), 0.0, 1e-6);
  EXPECT_NEAR(north.y(), 1105.74, 0.01);
  EXPECT_NEAR(north.z(), -0.0959, 0.001);
  // One degree of longitude at the equator is 111319.49 m (equatorial radius * pi / 180).
  EXPECT_NEAR(enu.toEnu(0.0, 0.001, 0.0).x(), 111.31949, 1e-4);
  EXPECT_NEAR(enu.toEnu(0.0, 0.0, 10.0).z(), 10.0, 1e-9);
}

TEST(Geodesy, RoundTripAtSeveralLatitudes) {
  for (double lat : {-89.9, -60.0, -12.5, 0.0, 24.4672, 48.262, 70.0, 89.9}) {
    const EnuFrame enu({lat, 54.6, 5.0});
    for (const Eigen::Vector3d& p :
         {Eigen::Vector3d(1234.5, -2345.25, 12.0), Eigen::Vector3d(-20000.0, 15000.0, -50.0),
          Eigen::Vector3d(0.001, 0.002, 0.003)}) {
      const Datum g = enu.toGeodetic(p);
      EXPECT_LT((enu.toEnu(g.lat, g.lon, g.alt) - p).norm(), 1e-8) << "lat " << lat;
    }
  }
}

TEST(Geodesy, InvalidDatumIsRejected) {
  EXPECT_THROW(EnuFrame({91.0, 0.0, 0.0}), Error);
  EXPECT_THROW(EnuFrame({0.0, 181.0, 0.0}), Error);
  EXPECT_THROW(EnuFrame({std::nan(""), 0.0, 0.0}), Error);
  EXPECT_FALSE(isValidGeodetic(0.0, 0.0, 1e6));
  EXPECT_TRUE(isValidGeodetic(-90.0, 180.0, -100.0));
}

}  // namespace
}  // namespace flexcloud
