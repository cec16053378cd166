#include <gtest/gtest.h>

#include "flexcloud/input/gnss.h"
#include "flexcloud/params.h"

namespace flexcloud {
namespace {

RawFix fix(double t, double lat, double lon, double std_dev = 0.02, bool ok = true) {
  RawFix f;
  f.has_fix = ok;
  f.fix.stamp = t;
  f.fix.lat = lat;
  f.fix.lon = lon;
  f.fix.alt = 100.0;
  f.fix.std_enu.setConstant(std_dev);
  return f;
}

/// 10 m/s north from (48, 11): 1e-4 deg of latitude is ~11.1 m.
std::vector<RawFix> drive() {
  std::vector<RawFix> v;
  for (int k = 0; k < 20; ++k) v.push_back(fix(100.0 + k, 48.0 + 0.9e-4 * k, 11.0));
  return v;
}

/// The published method's preparation: no fusion, so the jump filter runs and fixes without a
/// covariance are dropped unless a default std-dev is given.
Params legacy() {
  Params p;
  p.fusion = false;
  return p;
}

TEST(Gnss, DatumIsTheEarliestValidFix) {
  auto v = drive();
  std::swap(v[0], v[5]);                              // out of order
  v.insert(v.begin(), fix(99.0, 0, 0, 0.02, false));  // NO_FIX earlier than all
  const PreparedGnss g = prepareGeodeticGnss(v, gnssOptions(Params{}));
  ASSERT_TRUE(g.datum);
  EXPECT_DOUBLE_EQ(g.datum->lat, 48.0);
  EXPECT_NEAR(g.points.front().position.norm(), 0.0, 1e-9);
  EXPECT_NEAR(g.points[1].position.y(), 10.0, 0.05);
  EXPECT_EQ(g.dropped.no_fix, 1u);
  for (std::size_t i = 1; i < g.points.size(); ++i) {
    EXPECT_LT(g.points[i - 1].stamp, g.points[i].stamp);
  }
}

TEST(Gnss, EveryDroppedFixIsCountedByReason) {
  auto v = drive();
  v.push_back(fix(120.0, std::nan(""), 11.0));  // invalid
  v.push_back(fix(121.0, 48.01, std::numeric_limits<double>::infinity()));
  v.push_back(fix(122.0, 48.0, 11.0, std::nan("")));  // unknown covariance
  v.push_back(fix(105.0, 48.0005, 11.0));             // duplicate stamp
  v[10].fix.lat += 0.01;                              // a 1.1 km jump for one fix
  v.push_back(fix(123.0, 48.0, 11.0, -1.0));          // negative std: invalid
  const PreparedGnss g = prepareGeodeticGnss(v, gnssOptions(legacy()));
  EXPECT_EQ(g.received, 25u);
  EXPECT_EQ(g.dropped.invalid, 3u);
  EXPECT_EQ(g.dropped.unknown_covariance, 1u);
  EXPECT_EQ(g.dropped.duplicate, 1u);
  EXPECT_EQ(g.dropped.outlier, 1u);
  EXPECT_EQ(g.points.size() + g.dropped.total(), g.received);
}

TEST(Gnss, ASustainedJumpAwayAndBackLosesExactlyTheFixesInBetween) {
  std::vector<RawFix> v;
  for (int k = 0; k < 200; ++k) v.push_back(fix(100.0 + 0.2 * k, 48.0 + 0.18e-4 * k, 11.0));
  for (int k = 60; k < 90; ++k) v[k].fix.lon += 0.005;    // 6 s 370 m east, then back
  for (int k = 150; k < 151; ++k) v[k].fix.lat -= 0.004;  // and one fix 440 m south
  const PreparedGnss g = prepareGeodeticGnss(v, gnssOptions(legacy()));
  EXPECT_EQ(g.dropped.outlier, 31u);
  EXPECT_EQ(g.points.size(), 169u);
  for (const auto& p : g.points) EXPECT_LT(std::abs(p.position.x()), 1.0);  // none of the east ones
}

TEST(Gnss, AJumpAtTheStartIsTheMinorityNotTheReference) {
  std::vector<RawFix> v;
  for (int k = 0; k < 100; ++k) v.push_back(fix(100.0 + 0.2 * k, 48.0 + 0.18e-4 * k, 11.0));
  for (int k = 0; k < 10; ++k) v[k].fix.lon += 0.01;  // the first 2 s are 740 m off
  Params p = legacy();
  p.datum_lat = 48.0;
  p.datum_lon = 11.0;
  p.datum_alt = 0.0;
  const PreparedGnss g = prepareGeodeticGnss(v, gnssOptions(p));
  EXPECT_EQ(g.dropped.outlier, 10u);
  EXPECT_NEAR(g.points.front().stamp, 102.0, 1e-9);
  // Without a given datum, the datum is the earliest fix that was kept, not a jumped one.
  const PreparedGnss h = prepareGeodeticGnss(v, gnssOptions(legacy()));
  EXPECT_NEAR(h.datum->lon, 11.0, 1e-12);
  EXPECT_NEAR(h.datum->lat, 48.0 + 0.18e-4 * 10, 1e-12);
  EXPECT_LT(h.points.front().position.norm(), 1e-6);
}

TEST(Gnss, DefaultStdDevKeepsFixesWithUnknownCovariance) {
  auto v = drive();
  for (auto& f : v) f.fix.std_enu.setConstant(std::nan(""));
  Params p = legacy();
  p.default_std_dev = 0.5;
  const PreparedGnss g = prepareGeodeticGnss(v, gnssOptions(p));
  EXPECT_EQ(g.points.size(), v.size());
  EXPECT_DOUBLE_EQ(g.points[0].std_dev.x(), 0.5);
  try {  // all dropped: a clear error that says what keeps them
    prepareGeodeticGnss(v, gnssOptions(legacy()));
    FAIL();
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("unknown covariance " + std::to_string(v.size())), std::string::npos)
        << what;
    EXPECT_NE(what.find("need default_std_dev, or fusion true"), std::string::npos) << what;
  }
}

TEST(Gnss, WithTheFusionNothingIsDroppedForJumpsOrUnknownCovariance) {
  auto v = drive();
  v[10].fix.lat += 0.01;                        // a 1.1 km jump: the fusion judges it
  v[12].fix.std_enu.setConstant(std::nan(""));  // no covariance: estimated by the fusion
  v[14].fix.std_enu.setZero();                  // a std-dev of 0 means "not given"
  const PreparedGnss g = prepareGeodeticGnss(v, gnssOptions(Params{}));
  EXPECT_EQ(g.points.size(), v.size());
  EXPECT_EQ(g.dropped.total(), 0u);
  EXPECT_TRUE(g.points[12].std_dev.hasNaN());
  EXPECT_TRUE(g.points[14].std_dev.hasNaN());
  EXPECT_DOUBLE_EQ(g.points[0].std_dev.x(), 0.02);
  EXPECT_NEAR(g.points[10].position.y(), 1112.0 + 10 * 10.0, 5.0);
}

TEST(Gnss, GivenDatumAndTimeOffset) {
  Params p;
  p.datum_lat = 48.0;
  p.datum_lon = 11.0;
  p.datum_alt = 0.0;
  p.gnss_time_offset = -0.25;
  const PreparedGnss g = prepareGeodeticGnss(drive(), gnssOptions(p));
  EXPECT_NEAR(g.points[0].position.z(), 100.0, 1e-6);
  EXPECT_DOUBLE_EQ(g.points[0].stamp, 99.75);
}

TEST(Gnss, NoFixAtAllIsAnErrorThatSaysWhy) {
  std::vector<RawFix> v{fix(1, 0, 0, 0.02, false), fix(2, 0, 0, 0.02, false)};
  try {
    prepareGeodeticGnss(v, gnssOptions(Params{}));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no fix 2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace flexcloud
