#pragma once
// YAML parameter files (config/georeference.yaml): a map of key: value, keys from a parameter
// table. The offline tool reads them with --config; the ROS node loads the same file as rosparams.

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "flexcloud/param_table.h"

namespace flexcloud {

/// The key: value pairs of a YAML map file, each converted by the spec `find` returns for its
/// key (ranges as a list of [begin, end] pairs, .nan for an unset number). Throws Error
/// "FILE: ..." for a missing or malformed file, an unknown key (find returns null) or a value of
/// the wrong type.
std::vector<std::pair<std::string, ParamValue>> readParamYaml(
    const std::string& path, const std::function<const ParamSpec*(const std::string&)>& find);

/// Overwrites the fields of `s` that the file names (see readParamYaml).
template <class S>
void loadParamsYaml(const std::string& path, const ParamTable<S>& table, S& s) {
  const auto values = readParamYaml(path, [&](const std::string& key) -> const ParamSpec* {
    const auto* row = table.find(key);
    return row != nullptr ? &row->spec : nullptr;
  });
  for (const auto& [key, value] : values) table.set(s, key, value);
}

}  // namespace flexcloud
