#include <gtest/gtest.h>

#include <fstream>

#include "flexcloud/io/config.h"
#include "flexcloud/io/param_table.h"

namespace flexcloud {
namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

TEST(Params, DefaultsAreValid) { EXPECT_EQ(Params{}.validate(), ""); }

TEST(Params, ValidateNamesEveryBadValue) {
  Params p;
  p.control_points = 2;
  p.stddev_threshold = -1.0;
  p.datum_lat = 48.0;  // without lon/alt
  p.excluded_ranges = {{5.0, 1.0}};
  const std::string bad = p.validate();
  EXPECT_NE(bad.find("control_points 2 is not in [4, 1000000]"), std::string::npos) << bad;
  EXPECT_NE(bad.find("stddev_threshold -1"), std::string::npos) << bad;
  EXPECT_NE(bad.find("give all three or none"), std::string::npos) << bad;
  EXPECT_NE(bad.find("excluded_ranges [5, 1]"), std::string::npos) << bad;
}

TEST(Params, YamlUsesTheFieldNames) {
  const std::string path = writeTemp("cfg.yaml",
                                     "control_points: 50\nstddev_threshold: 0.05\n"
                                     "interpolation: nearest\nexcluded_ranges: [[1, 2], [5, 6.5]]\n"
                                     "enu_frame: world\n");
  Params p;
  loadParamsYaml(path, p);
  EXPECT_EQ(p.control_points, 50);
  EXPECT_DOUBLE_EQ(p.stddev_threshold, 0.05);
  EXPECT_EQ(p.interpolation, InterpolationMode::kNearest);
  ASSERT_EQ(p.excluded_ranges.size(), 2u);
  EXPECT_DOUBLE_EQ(p.excluded_ranges[1].end, 6.5);
}

TEST(Params, YamlMistakesAreOneLineErrors) {
  Params p;
  try {
    loadParamsYaml(writeTemp("bad1.yaml", "control_pionts: 50\n"), p);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown parameter 'control_pionts'"), std::string::npos);
  }
  try {
    loadParamsYaml(writeTemp("bad2.yaml", "control_points: many\n"), p);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("control_points: 'many' is not a number"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(loadParamsYaml(writeTemp("bad3.yaml", "control_points: [1\n"), p), Error);
  EXPECT_THROW(loadParamsYaml(writeTemp("bad4.yaml", "control_points: 2.5\n"), p), Error);
  EXPECT_THROW(loadParamsYaml("/nonexistent.yaml", p), Error);
}

TEST(Params, SetParamFromText) {
  Params p;
  setParam(p, "margin_z", "3.5");
  setParam(p, "excluded_ranges", "1:2,3:4");
  EXPECT_DOUBLE_EQ(p.margin_z, 3.5);
  EXPECT_EQ(p.excluded_ranges.size(), 2u);
  EXPECT_THROW(setParam(p, "interpolation", "linear"), Error);
  EXPECT_THROW(setParam(p, "excluded_ranges", "1-2"), Error);
}

}  // namespace
}  // namespace flexcloud
