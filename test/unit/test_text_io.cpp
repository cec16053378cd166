#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "flexcloud/io/text_io.h"

namespace flexcloud {
namespace {

TEST(TextIo, TumWithNanosecondStampsIsDetected) {
  const auto t = parseTum(
      "# comment\n1746076987991696384 22.0888 -0.05374 -0.837024 0.04964 0.004098 -0.018225 "
      "0.998592\n\n1746076988391703296 24.5816 -0.1 -0.8 0 0 0 1\n",
      "poses.txt", StampUnit::kAuto);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_NEAR(t[0].stamp, 1746076987.991696384, 1e-6);
  EXPECT_NEAR(t[1].stamp - t[0].stamp, 0.400006912, 1e-6);
  EXPECT_DOUBLE_EQ(t[0].position.x(), 22.0888);
  EXPECT_DOUBLE_EQ(t[0].orientation.w(), 0.998592);
}

TEST(TextIo, SecondsStayAndCommasAreSeparators) {
  const auto t = parseTum("12.5,1,2,3,0,0,0,1\n13,1,2,3,0,0,0,1\n", "p.csv", StampUnit::kAuto);
  EXPECT_DOUBLE_EQ(t[0].stamp, 12.5);
  EXPECT_DOUBLE_EQ(t[1].stamp, 13.0);
  const auto ns = parseTum("1000 1 2 3 0 0 0 1\n", "p", StampUnit::kNanoseconds);
  EXPECT_DOUBLE_EQ(ns[0].stamp, 1e-6);
}

TEST(TextIo, AHeaderLineIsSkipped) {
  const auto g = parseGeodeticGnss("stamp,lat,lon,alt\n10,48.1,11.2,500\n11,48.2,11.3,501\n",
                                   "g.csv", StampUnit::kAuto);
  ASSERT_EQ(g.size(), 2u);
  EXPECT_DOUBLE_EQ(g[0].fix.stamp, 10.0);
  EXPECT_DOUBLE_EQ(g[1].fix.lat, 48.2);
  const auto t = parseTum("# TUM poses\ntimestamp tx ty tz qx qy qz qw\n5 1 2 3 0 0 0 1\n", "p",
                          StampUnit::kAuto);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_DOUBLE_EQ(t[0].position.z(), 3.0);
  // Only the first line may be a header: text after the data is an error with its line.
  try {
    parseTum("5 1 2 3 0 0 0 1\nstamp x y z qx qy qz qw\n", "poses.txt", StampUnit::kAuto);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "poses.txt:2: 'stamp' is not a number");
  }
}

TEST(TextIo, StampUnitsAreDetectedBySizeOrGiven) {
  const std::string rest = " 1 2 3 0 0 0 1\n";
  const double t0 = 1700000000.25;
  // Unix epochs in s, ms, us and ns (as integers and as floats) all read as the same second.
  for (const std::string stamp :
       {"1700000000.25", "1700000000250", "1700000000250.0", "1700000000250000",
        "1700000000250000000", "1.70000000025e18", "1700000000250000000.0"}) {
    const auto t = parseTum(stamp + rest, "p", StampUnit::kAuto);
    EXPECT_NEAR(t[0].stamp, t0, 1e-6) << stamp;
  }
  // Stamps from 0 read as seconds unless the unit is given.
  EXPECT_DOUBLE_EQ(parseTum("1500" + rest, "p", StampUnit::kAuto)[0].stamp, 1500.0);
  EXPECT_DOUBLE_EQ(parseTum("1500" + rest, "p", StampUnit::kMilliseconds)[0].stamp, 1.5);
  EXPECT_DOUBLE_EQ(parseTum("1500" + rest, "p", StampUnit::kMicroseconds)[0].stamp, 0.0015);
  EXPECT_DOUBLE_EQ(parseTum("1500.5" + rest, "p", StampUnit::kMicroseconds)[0].stamp, 0.0015005);
  // Integer microseconds at Unix epochs keep what a double holds (0.24 us).
  const auto us = parseTum("1700000000000001" + rest + "1700000000000003" + rest, "p",
                           StampUnit::kMicroseconds);
  EXPECT_NEAR(us[1].stamp - us[0].stamp, 2e-6, 3e-7);
  EXPECT_EQ(parseStampUnit("us"), StampUnit::kMicroseconds);
  EXPECT_EQ(parseStampUnit("ms"), StampUnit::kMilliseconds);
  EXPECT_THROW(parseStampUnit("min"), Error);
}

TEST(TextIo, AByteOrderMarkIsSkipped) {
  const auto t = parseTum(
      "\xEF\xBB\xBF"
      "1700000000.000000 1 2 3 0 0 0 1\n",
      "bom.txt", StampUnit::kAuto);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_DOUBLE_EQ(t[0].stamp, 1700000000.0);
  EXPECT_DOUBLE_EQ(t[0].position.x(), 1.0);
}

TEST(TextIo, ErrorsNameTheFileAndLine) {
  try {
    parseTum("1 2 3 4 0 0 0 1\n2 3 4 5 6\n", "poses.txt", StampUnit::kAuto);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "poses.txt:2: expected stamp x y z qx qy qz qw (8 columns), found 5");
  }
  try {
    parseLocalGnss("1 2 3 4 0 0 0\n1.5 2 three 4\n", "gnss.txt", StampUnit::kAuto);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "gnss.txt:2: 'three' is not a number");
  }
  EXPECT_THROW(readTumFile("/nonexistent/poses.txt"), Error);
}

TEST(TextIo, GnssWithoutStdDevHasUnknownCovariance) {
  const auto g =
      parseGeodeticGnss("10 48.1 11.2 500\n11 48.1 11.2 500 0.1 0.2 0.3\n", "g", StampUnit::kAuto);
  EXPECT_TRUE(g[0].fix.std_enu.hasNaN());
  EXPECT_DOUBLE_EQ(g[1].fix.std_enu.z(), 0.3);
}

TEST(TextIo, TumRoundTrip) {
  Trajectory t(1);
  t[0].stamp = 1700000000.123456789;
  t[0].position = Eigen::Vector3d(1234.5678901, -2.25, 0.5);
  t[0].orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  const auto back = parseTum(formatTum(t), "x", StampUnit::kSeconds);
  EXPECT_NEAR(back[0].stamp, t[0].stamp, 1e-6);
  EXPECT_LT((back[0].position - t[0].position).norm(), 1e-6);
  EXPECT_NEAR(back[0].orientation.angularDistance(t[0].orientation), 0.0, 1e-8);
}

TEST(TextIo, FixedTextIsWhatPrintfWrites) {
  const double values[] = {0.0,
                           -0.0,
                           0.5,
                           -2.25,
                           1e-7,
                           -1e-7,
                           0.0000005,
                           0.0000015,
                           2.5e-10,
                           1234.5678905,
                           1700000000.123456789,
                           6e15,
                           -1e300,
                           1e308,
                           std::nextafter(1.0, 2.0),
                           0.1 + 0.2};
  for (const double v : values) {
    for (const int decimals : {0, 3, 6, 9, 17}) {
      std::string ours;
      appendFixed(ours, v, decimals);
      char theirs[400];
      std::snprintf(theirs, sizeof theirs, "%.*f", decimals, v);
      EXPECT_EQ(ours, theirs) << v << " with " << decimals << " decimals";
    }
  }
  Trajectory t(1);
  t[0].stamp = 1700000000.5;
  t[0].position = Eigen::Vector3d(-0.0000006, 1.25, 3e6);
  t[0].orientation = Eigen::Quaterniond(1.0, 0.0, 0.0, 0.0);
  EXPECT_EQ(formatTum(t),
            "1700000000.500000000 -0.000001 1.250000 3000000.000000 0.000000000 0.000000000 "
            "0.000000000 1.000000000\n");
}

}  // namespace
}  // namespace flexcloud
