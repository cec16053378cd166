#include "flexcloud/sim/scenarios.h"

#include <algorithm>

namespace flexcloud::sim {

const std::vector<std::string>& scenarioNames() {
  static const std::vector<std::string> names = {
      "loop_rtk",       "open_rtk",         "loop_urban",        "open_urban",
      "open_urban_end", "loop_urban_nocov", "loop_offset_lever", "open_rtk_drifting"};
  return names;
}

SimParams scenario(const std::string& name, std::uint64_t seed, std::size_t map_points) {
  const auto& names = scenarioNames();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    throw Error("unknown scenario '" + name + "'");
  }
  SimParams sp;
  sp.seed = seed;
  sp.map_points = map_points;
  sp.loop = name.rfind("open", 0) != 0;
  if (name.find("urban") != std::string::npos) sp.gnss_errors = urbanGnss();
  if (name == "open_urban_end") {
    sp.gnss_errors.multipath_jitter = 0.0;
    sp.gnss_errors.end_false_rtk_s = 35.0;
  }
  if (name == "open_rtk_drifting") {
    // A SLAM whose rotation wanders ten times as much (0.9 deg/sqrt(km) against the fusion's
    // default slam_rotation_noise of 0.2).
    sp.rotation_walk *= 10.0;
  }
  if (name == "loop_urban_nocov") sp.gnss_errors.no_covariance_share = 1.0;
  if (name == "loop_offset_lever") {
    // A clock offset moves fixes along the track: it shows only where the speed changes.
    sp.stop_duration = 20.0;
    sp.clock_offset = 0.5;
    sp.lever_arm = Eigen::Vector3d(1.2, -0.4, 1.6);
  }
  return sp;
}

}  // namespace flexcloud::sim
