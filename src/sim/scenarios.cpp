#include "flexcloud/sim/scenarios.h"

#include <algorithm>

namespace flexcloud::sim {
namespace {

/// The drives of the first study: the steady drift of SimParams, RTK or urban GNSS.
void steadyScenario(const std::string& name, SimParams& sp) {
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
    sp.clock_offset = -0.5;
    sp.lever_arm = Eigen::Vector3d(1.2, -0.4, 1.6);
  }
}

/// City driving: slower in the curves (2 m/s^2 across), up to 14 m/s on the straights.
void cityMotion(SimParams& sp) {
  sp.max_speed = 14.0;
  sp.max_lateral_accel = 2.0;
  sp.max_accel = 2.0;
  sp.max_brake = 3.0;
}

/// LiDAR odometry whose drift changes with what it sees: a third of the stretches poor in
/// features, the rotation walk there up to 20 times as strong, the heading rate changing by
/// 0.1 deg/100 m from stretch to stretch.
void varyingDrift(SimParams& sp) {
  sp.slam_errors.degenerate_share = 0.3;
  sp.slam_errors.walk_factor_max = 20.0;
  sp.slam_errors.heading_bias_change = 0.1;
}

/// The drives of SLAM failures the fusion does not model (doc/ACCURACY.md), each with the
/// SLAM's stamps off the GNSS's by its own amount, driven as in a city but for the race track.
/// clock_offset is the SLAM clock minus the GNSS clock (as gnss_time_offset): a SLAM whose
/// stamps lag by 0.47 s has 0.47.
void failureScenario(const std::string& name, SimParams& sp) {
  cityMotion(sp);
  if (name == "open_varying_drift") {
    sp.loop = false;
    varyingDrift(sp);
    sp.clock_offset = -0.25;
  } else if (name == "loop_closures") {
    // Three laps of 2 km; the pose graph closes each lap and leaves a snap of 0.5-3 m.
    sp.length = 2000.0;
    sp.laps = 3;
    sp.heading_bias = 0.3;
    sp.slam_errors.closures = true;
    sp.clock_offset = 0.2;
  } else if (name == "open_height_drift") {
    // The height drifts by tens of metres on its own, without any pitch error.
    sp.loop = false;
    sp.slam_errors.grade_error = 0.004;
    sp.slam_errors.grade_walk = 0.004;
    sp.clock_offset = -0.6;
  } else if (name == "race_track") {
    // 60-80 m/s, braking hard into the curves; 10 Hz RTK; the SLAM a scan late; its height
    // drifting as a race car's LiDAR odometry's does.
    sp.max_speed = 80.0;
    sp.max_lateral_accel = 25.0;
    sp.max_accel = 8.0;
    sp.max_brake = 25.0;
    sp.gnss_rate = 10.0;
    sp.odom_rate = 20.0;
    sp.slam_errors.grade_error = 0.002;
    sp.slam_errors.grade_walk = 0.002;
    sp.clock_offset = 0.1;
  } else if (name == "urban_keyframes_1hz") {
    // A city drive with stops: keyframes every 1-3 m, urban GNSS at 1 Hz without any
    // covariance, the keyframes' stamps half a second late.
    sp.stop_duration = 20.0;
    sp.gnss_rate = 1.0;
    sp.gnss_errors = urbanGnss();
    sp.gnss_errors.no_covariance_share = 1.0;
    sp.slam_errors.keyframe_min_m = 1.0;
    sp.slam_errors.keyframe_max_m = 3.0;
    varyingDrift(sp);
    sp.clock_offset = 0.47;
  } else if (name == "city_ins_10hz") {
    // GNSS/INS of reference grade at 10 Hz (5 mm of white noise, 2 cm wandering over 20 s),
    // visual SLAM whose stamps lead by 0.12 s: the clock must come out to a few milliseconds.
    sp.gnss_rate = 10.0;
    sp.gnss_noise_h = 0.005;
    sp.gnss_noise_v = 0.01;
    sp.reported_std_h = 0.02;
    sp.reported_std_v = 0.04;
    sp.gnss_errors.correlated_m = 0.02;
    sp.gnss_errors.correlated_tau_s = 20.0;
    varyingDrift(sp);
    sp.clock_offset = -0.12;
  } else if (name == "loop_unclosed") {
    // Ends where it began, odometry without loop closure (0.4 % of drift, as LiDAR odometry
    // has): the two ends lie some 20 m apart in the SLAM's map, the last stretch alongside the
    // first.
    sp.close_loop = false;
    sp.heading_bias = 0.03;
    sp.pitch_bias = 0.012;
  } else if (name == "open_gnss_late") {
    // An open route whose receiver gives its first fix 30 s after the SLAM starts (a cold start
    // in a car park) and its last 30 s before the SLAM stops (the next car park), with the
    // varying drift of LiDAR odometry: nothing but the SLAM speaks for the first and last
    // 300 m. The clocks agree: a drive's offset shows where it starts and stops, which the
    // fixes leave out here.
    sp.loop = false;
    sp.gnss_late_s = 30.0;
    sp.gnss_early_s = 30.0;
    varyingDrift(sp);
  } else if (name == "figure_eight") {
    // Crosses itself on a 7 m bridge: one place, two heights, the drift between the passes.
    sp.figure_eight = true;
    sp.heading_bias = 0.2;
  }
}

bool isFailureScenario(const std::string& name) {
  const auto& f = failureScenarioNames();
  return std::find(f.begin(), f.end(), name) != f.end();
}

}  // namespace

const std::vector<std::string>& scenarioNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n = {"loop_rtk",          "open_rtk",         "loop_urban",
                                  "open_urban",        "open_urban_end",   "loop_urban_nocov",
                                  "loop_offset_lever", "open_rtk_drifting"};
    for (const auto& f : failureScenarioNames()) n.push_back(f);
    return n;
  }();
  return names;
}

const std::vector<std::string>& failureScenarioNames() {
  static const std::vector<std::string> names = {
      "open_varying_drift", "loop_closures",       "open_height_drift",
      "race_track",         "urban_keyframes_1hz", "city_ins_10hz",
      "loop_unclosed",      "figure_eight",        "open_gnss_late"};
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
  if (isFailureScenario(name)) {
    failureScenario(name, sp);
  } else {
    steadyScenario(name, sp);
  }
  return sp;
}

}  // namespace flexcloud::sim
