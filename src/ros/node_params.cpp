#include "flexcloud/ros/node_params.h"

#include <dynamic_reconfigure/config_tools.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace flexcloud {
namespace {

using N = NodeParams;

ParamTable<N> makeNodeTable() {
  std::vector<ParamRow<N>> rows = paramTable().lifted(&N::core);
  std::vector<ParamRow<N>> own = {
      textRow<N>("enu_frame", &N::enu_frame, "enu", "Frame of the georeferenced outputs"),
      textRow<N>("map_frame", &N::map_frame, "",
                 "Frame of the SLAM map and poses; empty: the frame id of the incoming poses"),
      choiceRow<N>("odom_type", &N::odom_type, "odometry", {"odometry", "pose", "path"},
                   "Type on the odom topic: nav_msgs/Odometry, geometry_msgs/PoseStamped or "
                   "nav_msgs/Path (the latest path replaces all poses)"),
      textRow<N>("body_frame", &N::body_frame, "",
                 "Frame of the body the poses are of; empty: the odometry's child frame id"),
      boolRow<N>("lever_arm_from_tf", &N::lever_arm_from_tf, true,
                 "Take the lever arm from TF (body frame to the fixes' frame id) when it is there"),
      textRow<N>("bag", &N::bag, "", "Read fix and odom from this bag instead of subscribing"),
      textRow<N>("map_file", &N::map_file, "",
                 "PCD map to warp; empty: the latest PointCloud2 on the map topic"),
      boolRow<N>("georeference_on_bag_end", &N::georeference_on_bag_end, false,
                 "Georeference as soon as the bag has been read"),
      realRow<N>("recompute_delay", &N::recompute_delay, 0.5, 0.0, 60.0, "s",
                 "Wait after a dynamic_reconfigure change before recomputing (the latest wins)"),
      intRow<N>("max_messages", &N::max_messages, 2000000, 1000, 100000000, "",
                "Most fixes and poses kept each; beyond it the oldest half is dropped, counted"),
      intRow<N>("queue_size", &N::queue_size, 5000, 1, 1000000, "", "Subscriber queue length"),
  };
  rows.insert(rows.end(), own.begin(), own.end());
  return ParamTable<N>(std::move(rows));
}

std::string join(const std::string& a, const std::string& b) {
  return a.empty() ? b : b.empty() ? a : a + "; " + b;
}

/// A value from the parameter server as its row's type; throws Error naming the key.
ParamValue fromXmlRpc(const ParamSpec& spec, XmlRpc::XmlRpcValue& v) {
  using X = XmlRpc::XmlRpcValue;
  const std::string& key = spec.name;
  if (v.getType() == X::TypeString) {
    if (spec.type == ParamType::kRanges) throw Error(key + ": expected a list of [begin, end]");
    return parseValue(spec, static_cast<std::string>(v));
  }
  switch (spec.type) {
    case ParamType::kReal:
    case ParamType::kInt: {
      char buf[64];
      if (v.getType() == X::TypeInt) return parseValue(spec, std::to_string(static_cast<int>(v)));
      if (v.getType() != X::TypeDouble) throw Error(key + ": expected a number");
      std::snprintf(buf, sizeof(buf), "%.17g", static_cast<double>(v));
      return parseValue(spec, buf);
    }
    case ParamType::kBool:
      if (v.getType() != X::TypeBoolean) throw Error(key + ": expected true or false");
      return ParamValue{static_cast<bool>(v) ? 1.0 : 0.0, "", {}};
    case ParamType::kText:
    case ParamType::kChoice:
      throw Error(key + ": expected a word");
    case ParamType::kRanges: {
      if (v.getType() != X::TypeArray) throw Error(key + ": expected a list of [begin, end]");
      ParamValue out;
      auto number = [&](X& x) {
        if (x.getType() == X::TypeInt) return static_cast<double>(static_cast<int>(x));
        if (x.getType() == X::TypeDouble) return static_cast<double>(x);
        throw Error(key + ": expected numbers in [begin, end]");
      };
      for (int i = 0; i < v.size(); ++i) {
        if (v[i].getType() != X::TypeArray || v[i].size() != 2) {
          throw Error(key + ": expected a list of [begin, end]");
        }
        out.ranges.push_back({number(v[i][0]), number(v[i][1])});
      }
      return out;
    }
  }
  return {};
}

}  // namespace

const ParamTable<NodeParams>& nodeParamTable() {
  static const ParamTable<NodeParams> table = makeNodeTable();
  return table;
}

NodeParams::NodeParams() { nodeParamTable().setDefaults(*this); }

std::string NodeParams::validate() const {
  std::string bad = join(nodeParamTable().validate(*this), core.ruleProblems());
  if (enu_frame.empty()) bad = join(bad, "enu_frame must not be empty");
  if (enu_frame == map_frame) bad = join(bad, "enu_frame and map_frame must differ");
  return bad;
}

std::string checkParam(const std::string& name, const ParamValue& value) {
  return checkValue(nodeParamTable().row(name).spec, value);
}

NodeParams loadNodeParams(const ros::NodeHandle& pnh) {
  NodeParams p;
  std::string problems;
  for (const auto& row : nodeParamTable().rows()) {
    XmlRpc::XmlRpcValue v;
    if (!pnh.getParam(row.spec.name, v)) continue;
    try {
      row.set(p, fromXmlRpc(row.spec, v));
    } catch (const Error& e) {
      problems = join(problems, e.what());
    }
  }
  problems = join(problems, p.validate());
  if (!problems.empty()) throw Error("parameters of " + pnh.getNamespace() + ": " + problems);
  return p;
}

std::vector<std::string> unknownNodeParams(const ros::NodeHandle& pnh) {
  std::vector<std::string> names;
  if (!pnh.getParamNames(names)) return {};
  const std::string prefix = pnh.getNamespace() + "/";
  std::vector<std::string> unknown;
  for (const auto& full : names) {
    if (full.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string name =
        full.substr(prefix.size(), full.find('/', prefix.size()) - prefix.size());
    if (nodeParamTable().find(name) == nullptr) unknown.push_back(name);
  }
  std::sort(unknown.begin(), unknown.end());
  unknown.erase(std::unique(unknown.begin(), unknown.end()), unknown.end());
  return unknown;
}

namespace {

/// "[min, max]" for numbers, the choices for words, "" otherwise.
std::string rangeOf(const ParamSpec& s) {
  if (s.type == ParamType::kReal || s.type == ParamType::kInt) {
    return "[" + formatValue(s, ParamValue{s.min, "", {}}) + ", " +
           formatValue(s, ParamValue{s.max, "", {}}) + "]";
  }
  std::string out;
  for (const auto& c : s.choices) out += (out.empty() ? "" : ", ") + c;
  return out;
}

/// The text with the characters a Markdown table cell cannot hold escaped.
std::string cell(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out.empty() ? " " : out;
}

}  // namespace

std::string parametersMarkdown() {
  std::string out =
      "# Parameters\n\n"
      "Generated from the parameter table (`src/core/params.cpp`, `src/ros/node_params.cpp`) by\n"
      "`scripts/env.sh rosrun flexcloud flexcloud_parameters > doc/PARAMETERS.md`; a test checks\n"
      "that this file matches the table. The same rows make `config/georeference.yaml`, the\n"
      "dynamic_reconfigure `cfg/Georeference.cfg` and what `--config`, `--set` and the node's\n"
      "rosparams accept.\n\n"
      "Where: `all` applies to the offline tool (`--config FILE`, `--set NAME=VALUE`) and the\n"
      "node (rosparam under its private name); `node` to the node only. Live: tunable while the\n"
      "node runs (dynamic_reconfigure); the others are read when the node starts.\n\n"
      "| name | default | range | unit | where | live | meaning |\n"
      "|---|---|---|---|---|---|---|\n";
  for (const auto& row : nodeParamTable().rows()) {
    const ParamSpec& s = row.spec;
    const bool core = paramTable().find(s.name) != nullptr;
    out += "| `" + s.name + "` | " + cell(formatValue(s, s.def)) + " | " + cell(rangeOf(s)) +
           " | " + cell(s.unit) + " | " + (core ? "all" : "node") + " | " +
           (s.live ? "yes" : "no") + " | " + cell(s.doc) + " |\n";
  }
  return out;
}

namespace {

/// The headings of config/georeference.yaml, each before the row it names.
const std::map<std::string, std::string>& yamlHeadings() {
  static const std::map<std::string, std::string> headings = {
      {"datum_lat", "The ENU datum; not set: the first valid fix."},
      {"default_std_dev", "GNSS input."},
      {"fusion", "Fusion of SLAM and GNSS before the control points are chosen."},
      {"interpolation", "Keyframe interpolation: the GNSS at the pose stamps."},
      {"control_points", "Control points."},
      {"beside_distance", "Control points beside and above the trajectory."},
      {"margin_x", "The rubber sheet's enclosing cuboid."},
      {"max_uncovered_share", "Reporting and execution."},
      {"autoware", "Outputs beside the map."},
      {"enu_frame", "The ROS node only (the offline tool accepts and ignores them)."}};
  return headings;
}

/// The default as YAML spells it: quoted when empty, a list for time ranges.
std::string yamlValue(const ParamSpec& s) {
  if (s.type == ParamType::kRanges) {
    std::string out;
    for (const auto& r : s.def.ranges) {
      out += (out.empty() ? "" : ", ") + std::string("[") +
             formatValue(ParamSpec{}, ParamValue{r.begin, "", {}}) + ", " +
             formatValue(ParamSpec{}, ParamValue{r.end, "", {}}) + "]";
    }
    return "[" + out + "]";
  }
  const std::string text = formatValue(s, s.def);
  return text.empty() ? "\"\"" : text;
}

/// "# MEANING (a | b | c) [UNIT]" for the line of a row.
std::string yamlComment(const ParamSpec& s) {
  std::string out = "# " + s.doc;
  for (std::size_t i = 0; i < s.choices.size(); ++i) {
    out += (i == 0 ? " (" : " | ") + s.choices[i] + (i + 1 == s.choices.size() ? ")" : "");
  }
  return out + (s.unit.empty() ? "" : " [" + s.unit + "]");
}

}  // namespace

std::string parametersYaml() {
  // What the file is for, and the command that writes it.
  std::string out =
      "# flexcloud's parameters at their defaults (ranges: doc/PARAMETERS.md), for --config and\n"
      "# the node's rosparams. Made from the parameter table by `scripts/env.sh rosrun flexcloud\n"
      "# flexcloud_parameters --yaml > config/georeference.yaml`; a test checks they agree.\n";
  for (const auto& row : nodeParamTable().rows()) {
    const ParamSpec& s = row.spec;
    const auto heading = yamlHeadings().find(s.name);
    if (heading != yamlHeadings().end()) out += "\n# " + heading->second + "\n";
    const bool unset = s.nan_unset && std::isnan(s.def.number);
    std::string line = (unset ? "# " : "") + s.name + ": " + (unset ? "" : yamlValue(s));
    line.resize(std::max<std::size_t>(line.size() + 1, 30), ' ');
    out += line + yamlComment(s) + "\n";
  }
  return out;
}

// dynamic_reconfigure keeps a config as a message of named ints, doubles, strs and bools; the
// table's live rows are copied through that form, so no field is named twice.
namespace {

template <class Entry, class T>
bool setEntry(std::vector<Entry>& entries, const std::string& name, const T& value) {
  for (auto& e : entries) {
    if (e.name == name) {
      e.value = value;
      return true;
    }
  }
  return false;
}

template <class Entry>
const Entry* findEntry(const std::vector<Entry>& entries, const std::string& name) {
  for (const auto& e : entries) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

}  // namespace

void toConfig(const NodeParams& p, GeoreferenceConfig& config) {
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  for (const auto& row : nodeParamTable().rows()) {
    if (!row.spec.live) continue;
    const ParamValue v = row.get(p);
    const std::string& name = row.spec.name;
    bool found = false;
    switch (row.spec.type) {
      case ParamType::kReal:
        found = setEntry(msg.doubles, name, v.number);
        break;
      case ParamType::kInt:
        found = setEntry(msg.ints, name, static_cast<int>(v.number));
        break;
      case ParamType::kBool:
        found = setEntry(msg.bools, name, static_cast<std::uint8_t>(v.number != 0.0));
        break;
      case ParamType::kText:
      case ParamType::kChoice:
        found = setEntry(msg.strs, name, v.text);
        break;
      case ParamType::kRanges:
        break;
    }
    if (!found) throw Error("dynamic_reconfigure has no " + typeName(row.spec.type) + " " + name);
  }
  config.__fromMessage__(msg);
}

NodeParams fromConfig(const GeoreferenceConfig& config, NodeParams p) {
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  for (const auto& row : nodeParamTable().rows()) {
    if (!row.spec.live) continue;
    const std::string& name = row.spec.name;
    ParamValue v;
    bool found = false;
    if (const auto* d = findEntry(msg.doubles, name); d && row.spec.type == ParamType::kReal) {
      v.number = d->value, found = true;
    } else if (const auto* i = findEntry(msg.ints, name); i && row.spec.type == ParamType::kInt) {
      v.number = i->value, found = true;
    } else if (const auto* b = findEntry(msg.bools, name); b && row.spec.type == ParamType::kBool) {
      v.number = b->value ? 1.0 : 0.0, found = true;
    } else if (const auto* t = findEntry(msg.strs, name)) {
      v = parseValue(row.spec, t->value), found = true;
    }
    if (!found) throw Error("dynamic_reconfigure has no " + typeName(row.spec.type) + " " + name);
    row.set(p, v);
  }
  return p;
}

}  // namespace flexcloud
