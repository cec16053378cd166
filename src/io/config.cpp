#include "flexcloud/io/config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>

#include "flexcloud/io/param_table.h"
#include "flexcloud/io/text_io.h"

namespace flexcloud {

const std::vector<std::string>& nodeOnlyKeys() {
  // The fields of NodeParams (include/flexcloud/ros/node_params.h) beyond the core ones.
  static const std::vector<std::string> keys = {
      "enu_frame",       "map_frame",    "odom_type",  "bag", "map_file", "georeference_on_bag_end",
      "recompute_delay", "max_messages", "queue_size"};
  return keys;
}

void loadParamsYaml(const std::string& path, Params& params) {
  const std::string text = readWholeFile(path);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw Error(path + ": not valid YAML: " + e.what());
  }
  if (root.IsNull()) return;
  if (!root.IsMap()) throw Error(path + ": expected a map of key: value");
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    try {
      if (key == "excluded_ranges") {
        params.excluded_ranges.clear();
        if (!v.IsSequence()) throw Error("expected a list of [begin, end] pairs");
        for (const auto& r : v) {
          if (!r.IsSequence() || r.size() != 2) throw Error("expected a list of [begin, end] pairs");
          params.excluded_ranges.push_back({r[0].as<double>(), r[1].as<double>()});
        }
      } else if (std::find(nodeOnlyKeys().begin(), nodeOnlyKeys().end(), key) !=
                 nodeOnlyKeys().end()) {
        continue;
      } else {
        if (!v.IsScalar()) throw Error("expected a single value");
        setParam(params, key, v.Scalar());
      }
    } catch (const YAML::Exception& e) {
      throw Error(path + ": " + key + ": " + e.what());
    } catch (const Error& e) {
      const std::string what = e.what();
      throw Error(path + ": " + (what.rfind(key, 0) == 0 ? what : key + ": " + what));
    }
  }
}

}  // namespace flexcloud
