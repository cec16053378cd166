#include <gtest/gtest.h>

#include <cmath>

#include "flexcloud/io/config.h"
#include "flexcloud/params.h"
#include "test_util.h"

namespace flexcloud {
namespace {

using test::writeTempFile;

void load(const std::string& path, Params& p) { loadParamsYaml(path, paramTable(), p); }

TEST(Params, DefaultsAreValidAndComeFromTheTable) {
  const Params p;
  EXPECT_EQ(p.validate(), "");
  EXPECT_EQ(p.control_points, 200);
  EXPECT_DOUBLE_EQ(p.stddev_threshold, 0.1);
  EXPECT_EQ(p.interpolation, InterpolationMode::kSpline);
  EXPECT_TRUE(std::isnan(p.datum_lat));
  for (const auto& row : paramTable().rows()) {
    EXPECT_EQ(formatValue(row.spec, row.get(p)), formatValue(row.spec, row.spec.def))
        << row.spec.name;
    EXPECT_FALSE(row.spec.doc.empty()) << row.spec.name;
    EXPECT_EQ(row.spec.doc.find('\n'), std::string::npos) << row.spec.name;
  }
}

TEST(Params, ValidateNamesEveryBadValue) {
  Params p;
  p.control_points = 2;
  p.stddev_threshold = -1.0;
  p.datum_lat = 48.0;  // without lon/alt
  p.excluded_ranges = {{5.0, 1.0}};
  const std::string bad = p.validate();
  EXPECT_NE(bad.find("control_points 2 is not in [4, 100000]"), std::string::npos) << bad;
  EXPECT_NE(bad.find("stddev_threshold -1 m is not in [0.001, 100]"), std::string::npos) << bad;
  EXPECT_NE(bad.find("give all three or none"), std::string::npos) << bad;
  EXPECT_NE(bad.find("excluded_ranges [5, 1]"), std::string::npos) << bad;
}

TEST(Params, EveryRangeIsEnforcedAtItsBounds) {
  for (const auto& row : paramTable().rows()) {
    const ParamSpec& s = row.spec;
    if (s.type != ParamType::kReal && s.type != ParamType::kInt) continue;
    const double step = s.type == ParamType::kInt ? 1.0 : 1e-9 * std::max(1.0, std::abs(s.max));
    EXPECT_EQ(checkValue(s, ParamValue{s.min, "", {}}), "") << s.name;
    EXPECT_EQ(checkValue(s, ParamValue{s.max, "", {}}), "") << s.name;
    EXPECT_NE(checkValue(s, ParamValue{s.min - step, "", {}}), "") << s.name;
    EXPECT_NE(checkValue(s, ParamValue{s.max + step, "", {}}), "") << s.name;
    EXPECT_EQ(checkValue(s, ParamValue{std::nan(""), "", {}}).empty(), s.nan_unset) << s.name;
  }
}

TEST(Params, YamlUsesTheFieldNames) {
  const std::string path =
      writeTempFile("cfg.yaml",
                    "control_points: 50\nstddev_threshold: 0.05\n"
                    "interpolation: nearest\nexcluded_ranges: [[1, 2], [5, 6.5]]\n"
                    "datum_lat: .nan\n");
  Params p;
  load(path, p);
  EXPECT_EQ(p.control_points, 50);
  EXPECT_DOUBLE_EQ(p.stddev_threshold, 0.05);
  EXPECT_EQ(p.interpolation, InterpolationMode::kNearest);
  ASSERT_EQ(p.excluded_ranges.size(), 2u);
  EXPECT_DOUBLE_EQ(p.excluded_ranges[1].end, 6.5);
  EXPECT_TRUE(std::isnan(p.datum_lat));
}

TEST(Params, YamlMistakesAreOneLineErrors) {
  Params p;
  const std::string unknown =
      test::errorOf([&] { load(writeTempFile("bad1.yaml", "control_pionts: 50\n"), p); });
  EXPECT_NE(unknown.find("unknown parameter 'control_pionts'"), std::string::npos) << unknown;
  const std::string word =
      test::errorOf([&] { load(writeTempFile("bad2.yaml", "control_points: many\n"), p); });
  EXPECT_NE(word.find("control_points: 'many' is not a number"), std::string::npos) << word;
  EXPECT_THROW(load(writeTempFile("bad3.yaml", "control_points: [1\n"), p), Error);
  EXPECT_THROW(load(writeTempFile("bad4.yaml", "control_points: 2.5\n"), p), Error);
  EXPECT_THROW(load("/nonexistent.yaml", p), Error);
  // A node key is not a core parameter: the core table alone refuses it.
  EXPECT_THROW(load(writeTempFile("bad5.yaml", "enu_frame: world\n"), p), Error);
}

TEST(Params, SetFromText) {
  Params p;
  paramTable().setText(p, "margin_z", "3.5");
  paramTable().setText(p, "excluded_ranges", "1:2,3:4");
  EXPECT_DOUBLE_EQ(p.margin_z, 3.5);
  EXPECT_EQ(p.excluded_ranges.size(), 2u);
  EXPECT_THROW(paramTable().setText(p, "interpolation", "linear"), Error);
  EXPECT_THROW(paramTable().setText(p, "excluded_ranges", "1-2"), Error);
  EXPECT_THROW(paramTable().setText(p, "no_such_key", "1"), Error);
}

TEST(Params, TextRoundTripsThroughFormat) {
  Params p;
  p.margin_x = 0.123456789012345;
  p.excluded_ranges = {{1.5, 2.0}};
  Params q;
  for (const auto& row : paramTable().rows()) {
    paramTable().setText(q, row.spec.name, formatValue(row.spec, row.get(p)));
  }
  EXPECT_TRUE(paramTable().same(p, q));
  q.margin_x += 1e-12;
  EXPECT_FALSE(paramTable().same(p, q));
}

}  // namespace
}  // namespace flexcloud
