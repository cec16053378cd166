#pragma once
// The YAML config file: the same keys as the ROS parameters.

#include <string>

#include "flexcloud/params.h"

namespace flexcloud {

/// Keys of the ROS node's own parameters: allowed in a config file, not used by the core.
const std::vector<std::string>& nodeOnlyKeys();

/// Overwrites the fields of `params` that the file names. excluded_ranges is a list of
/// [begin, end] pairs. Throws Error "FILE: ..." for a missing or malformed file, an unknown key
/// or a value of the wrong type.
void loadParamsYaml(const std::string& path, Params& params);

}  // namespace flexcloud
