#include <gtest/gtest.h>

#include <limits>
#include <nlohmann/json.hpp>

#include "flexcloud/io/geojson.h"

namespace flexcloud {
namespace {

TEST(Geojson, ALineAcrossTheAntimeridianIsCutThere) {
  // Eastwards from 179.9 to -179.9 (0.2 degrees of travel), the latitude rising from 10 to 11.
  const auto parts =
      cutAtAntimeridian({{179.8, 9.5, 5.0}, {179.9, 10.0, 6.0}, {-179.9, 11.0, 8.0}});
  ASSERT_EQ(parts.size(), 2u);
  ASSERT_EQ(parts[0].size(), 3u);
  ASSERT_EQ(parts[1].size(), 2u);
  EXPECT_DOUBLE_EQ(parts[0].back().x(), 180.0);
  EXPECT_NEAR(parts[0].back().y(), 10.5, 1e-9);  // half-way
  EXPECT_NEAR(parts[0].back().z(), 7.0, 1e-9);
  EXPECT_DOUBLE_EQ(parts[1].front().x(), -180.0);
  EXPECT_NEAR(parts[1].front().y(), 10.5, 1e-9);
  EXPECT_DOUBLE_EQ(parts[1].back().x(), -179.9);
  // Westwards: the first part ends at -180.
  const auto west = cutAtAntimeridian({{-179.95, 0.0, 0.0}, {179.85, 1.0, 0.0}});
  ASSERT_EQ(west.size(), 2u);
  EXPECT_DOUBLE_EQ(west[0].back().x(), -180.0);
  EXPECT_NEAR(west[0].back().y(), 0.25, 1e-9);
  EXPECT_DOUBLE_EQ(west[1].front().x(), 180.0);
  // A line that stays on one side is one part, unchanged.
  const auto one = cutAtAntimeridian({{11.0, 48.0, 0.0}, {11.1, 48.1, 0.0}});
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].size(), 2u);
}

TEST(Geojson, ATrajectoryAcrossLongitude180IsAMultiLineString) {
  GeoreferenceResult r;
  r.datum = Datum{-16.5, 179.9995, 10.0};  // Fiji's Taveuni lies across longitude 180
  for (int i = -10; i <= 10; ++i) {
    Pose p;
    p.stamp = i;
    p.position = Eigen::Vector3d(10.0 * i, 0.0, 0.0);  // 100 m each side of the datum, eastwards
    r.aligned.push_back(p);
  }
  r.rubbersheet = r.aligned;
  const auto g = nlohmann::json::parse(trajectoriesGeojson(r));
  bool found = false;
  for (const auto& f : g["features"]) {
    if (f["properties"]["name"] != "corrected") continue;
    found = true;
    ASSERT_EQ(f["geometry"]["type"], "MultiLineString");
    const auto& parts = f["geometry"]["coordinates"];
    ASSERT_EQ(parts.size(), 2u);
    EXPECT_DOUBLE_EQ(parts[0].back()[0].get<double>(), 180.0);
    EXPECT_DOUBLE_EQ(parts[1].front()[0].get<double>(), -180.0);
    for (const auto& q : parts[0]) EXPECT_GT(q[0].get<double>(), 179.99);
    for (const auto& q : parts[1]) EXPECT_LT(q[0].get<double>(), -179.99);
  }
  EXPECT_TRUE(found);
}

// The corrected trajectory carries its poses' sigmas, in their order, rounded to 0.1 mm; an
// infinite one (no fix to rest on) is null, as JSON has no infinity.
TEST(Geojson, TheCorrectedTrajectoryCarriesItsSigmas) {
  GeoreferenceResult r;
  r.datum = Datum{48.262, 11.667, 480.0};
  for (int i = 0; i < 4; ++i) {
    Pose p;
    p.stamp = i;
    p.position = Eigen::Vector3d(10.0 * i, 0.0, 0.0);
    r.aligned.push_back(p);
  }
  r.rubbersheet = r.aligned;
  r.sigma.h = {0.01234, 0.02, 0.5, std::numeric_limits<double>::infinity()};
  r.sigma.v = {0.03, 0.03, 0.04, std::numeric_limits<double>::infinity()};
  r.sigma.median_h = 0.02;
  r.sigma.p95_h = 0.5;
  const auto g = nlohmann::json::parse(trajectoriesGeojson(r));
  bool found = false;
  for (const auto& f : g["features"]) {
    if (f["properties"]["name"] != "corrected") continue;
    found = true;
    const auto& h = f["properties"]["sigma_h_m"];
    ASSERT_EQ(h.size(), 4u);
    EXPECT_NEAR(h[0].get<double>(), 0.0123, 1e-12);
    EXPECT_NEAR(h[2].get<double>(), 0.5, 1e-12);
    EXPECT_TRUE(h[3].is_null());
    EXPECT_NEAR(f["properties"]["sigma_v_m"][2].get<double>(), 0.04, 1e-12);
    EXPECT_NEAR(f["properties"]["sigma_h_p95_m"].get<double>(), 0.5, 1e-12);
  }
  EXPECT_TRUE(found);
}

}  // namespace
}  // namespace flexcloud
