#include "flexcloud/io/config.h"

#include <yaml-cpp/yaml.h>

#include <cmath>

#include "flexcloud/io/text_io.h"

namespace flexcloud {
namespace {

ParamValue rangesFromYaml(const YAML::Node& v) {
  ParamValue out;
  if (!v.IsSequence()) throw Error("expected a list of [begin, end] pairs");
  for (const auto& r : v) {
    if (!r.IsSequence() || r.size() != 2) throw Error("expected a list of [begin, end] pairs");
    out.ranges.push_back({r[0].as<double>(), r[1].as<double>()});
  }
  return out;
}

ParamValue valueFromYaml(const ParamSpec& spec, const YAML::Node& v) {
  if (spec.type == ParamType::kRanges) return rangesFromYaml(v);
  if (!v.IsScalar()) throw Error("expected a single value");
  const std::string& text = v.Scalar();
  if (spec.type == ParamType::kReal && (text == ".nan" || text == ".NaN" || text == ".NAN")) {
    return ParamValue{std::nan(""), "", {}};
  }
  return parseValue(spec, text);
}

}  // namespace

std::vector<std::pair<std::string, ParamValue>> readParamYaml(
    const std::string& path, const std::function<const ParamSpec*(const std::string&)>& find) {
  const std::string text = readWholeFile(path);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw Error(path + ": not valid YAML: " + e.what());
  }
  std::vector<std::pair<std::string, ParamValue>> out;
  if (root.IsNull()) return out;
  if (!root.IsMap()) throw Error(path + ": expected a map of key: value");
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    const ParamSpec* spec = find(key);
    if (spec == nullptr) throw Error(path + ": unknown parameter '" + key + "'");
    try {
      out.emplace_back(key, valueFromYaml(*spec, kv.second));
    } catch (const YAML::Exception& e) {
      throw Error(path + ": " + key + ": " + e.what());
    } catch (const Error& e) {
      const std::string what = e.what();
      throw Error(path + ": " + (what.rfind(key, 0) == 0 ? what : key + ": " + what));
    }
  }
  return out;
}

}  // namespace flexcloud
