// The parameter table is the one description of every parameter: cfg/Georeference.cfg (through
// the config class dynamic_reconfigure generates from it) and config/georeference.yaml must agree
// with it. No ROS master needed.
#include <dynamic_reconfigure/Config.h>
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <regex>
#include <set>

#include "flexcloud/io/config.h"
#include "flexcloud/ros/node_params.h"

namespace flexcloud {
namespace {

using Config = GeoreferenceConfig;

/// The value of `name` in a config message, as the table's neutral form.
ParamValue valueIn(const dynamic_reconfigure::Config& msg, const std::string& name) {
  for (const auto& d : msg.doubles) {
    if (d.name == name) return {d.value, "", {}};
  }
  for (const auto& i : msg.ints) {
    if (i.name == name) return {static_cast<double>(i.value), "", {}};
  }
  for (const auto& b : msg.bools) {
    if (b.name == name) return {b.value ? 1.0 : 0.0, "", {}};
  }
  for (const auto& s : msg.strs) {
    if (s.name == name) return {0.0, s.value, {}};
  }
  ADD_FAILURE() << name << " is not in the config";
  return {};
}

dynamic_reconfigure::Config message(const Config& c) {
  dynamic_reconfigure::Config msg;
  c.__toMessage__(msg);
  return msg;
}

TEST(ParamFiles, ReconfigureOffersExactlyTheLiveRowsWithTheirTypesRangesAndText) {
  std::set<std::string> offered;
  for (const auto& d : Config::__getParamDescriptions__()) {
    offered.insert(d->name);
    const auto* row = nodeParamTable().find(d->name);
    ASSERT_NE(row, nullptr) << d->name << " is in the .cfg but not in the table";
    const ParamSpec& s = row->spec;
    EXPECT_TRUE(s.live) << s.name << " is in the .cfg but not live in the table";
    EXPECT_EQ(d->type, typeName(s.type)) << s.name;
    EXPECT_EQ(d->description, s.doc) << s.name;
    const auto def = valueIn(message(Config::__getDefault__()), s.name);
    EXPECT_EQ(formatValue(s, def), formatValue(s, s.def)) << s.name << " default";
    if (s.type == ParamType::kReal || s.type == ParamType::kInt) {
      EXPECT_EQ(valueIn(message(Config::__getMin__()), s.name).number, s.min) << s.name;
      EXPECT_EQ(valueIn(message(Config::__getMax__()), s.name).number, s.max) << s.name;
    }
    if (s.type == ParamType::kChoice) {
      for (const auto& c : s.choices) {
        EXPECT_NE(d->edit_method.find("'value': '" + c + "'"), std::string::npos)
            << s.name << " lacks the choice " << c;
      }
    }
  }
  for (const auto& row : nodeParamTable().rows()) {
    EXPECT_EQ(row.spec.live, offered.count(row.spec.name) == 1)
        << row.spec.name << ": live in the table iff in the .cfg";
  }
}

TEST(ParamFiles, ConfigRoundTripsThroughTheTable) {
  NodeParams p;
  p.core.control_points = 77;
  p.core.margin_z = 2.5;
  p.core.interpolation = InterpolationMode::kNearest;
  Config c = Config::__getDefault__();
  toConfig(p, c);
  EXPECT_EQ(c.control_points, 77);
  EXPECT_EQ(c.interpolation, "nearest");
  const NodeParams back = fromConfig(c, NodeParams{});
  EXPECT_TRUE(nodeParamTable().same(back, p));
  c.interpolation = "cubic";
  EXPECT_THROW(fromConfig(c, NodeParams{}), Error);
}

TEST(ParamFiles, TheYamlListsEveryRowAtItsDefault) {
  const std::string path = std::string(FLEXCLOUD_SOURCE_DIR) + "/config/georeference.yaml";
  const auto values = readParamYaml(path, [](const std::string& key) -> const ParamSpec* {
    const auto* row = nodeParamTable().find(key);
    return row != nullptr ? &row->spec : nullptr;
  });
  std::set<std::string> listed;
  for (const auto& [key, value] : values) {
    listed.insert(key);
    const ParamSpec& s = nodeParamTable().row(key).spec;
    EXPECT_EQ(formatValue(s, value), formatValue(s, s.def)) << key << " in " << path;
  }
  // A parameter without a default value (the datum) is shown commented out.
  std::ifstream in(path);
  const std::regex commented(R"(^#\s*([a-z_]+):)");
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, commented) && nodeParamTable().find(m[1])) listed.insert(m[1]);
  }
  for (const auto& row : nodeParamTable().rows()) {
    EXPECT_EQ(listed.count(row.spec.name), 1u) << row.spec.name << " is not in " << path;
  }
}

TEST(ParamFiles, TheYamlIsTheTable) {
  const std::string path = std::string(FLEXCLOUD_SOURCE_DIR) + "/config/georeference.yaml";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, parametersYaml())
      << path << " differs from the table: scripts/env.sh rosrun flexcloud flexcloud_parameters "
      << "--yaml > config/georeference.yaml";
}

TEST(ParamFiles, DocParametersIsTheTable) {
  const std::string path = std::string(FLEXCLOUD_SOURCE_DIR) + "/doc/PARAMETERS.md";
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, parametersMarkdown())
      << path << " differs from the table: scripts/env.sh rosrun flexcloud flexcloud_parameters > "
      << "doc/PARAMETERS.md";
  for (const auto& row : nodeParamTable().rows()) {
    EXPECT_NE(text.find("| `" + row.spec.name + "` |"), std::string::npos) << row.spec.name;
  }
}

}  // namespace
}  // namespace flexcloud
