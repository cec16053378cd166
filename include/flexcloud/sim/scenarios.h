#pragma once
// The named drives of the accuracy study (doc/ACCURACY.md), shared by flexcloud_accuracy and the
// end-to-end tests.

#include <string>
#include <vector>

#include "flexcloud/sim/drive_simulator.h"

namespace flexcloud::sim {

/// loop_rtk, open_rtk: clean RTK GNSS on a loop-closed loop and an open route; loop_urban,
/// open_urban: the urban GNSS of urbanGnss(); open_urban_end: its episodes without jitter and a
/// drive that ends in 35 s of false RTK fixes; loop_urban_nocov: urban GNSS without any
/// covariance; loop_offset_lever: a 0.5 s clock offset, a lever arm and a 20 s stop;
/// open_rtk_drifting: an open route with RTK GNSS whose SLAM rotation wanders ten times as much
/// as the default's (not among the targets: doc/ACCURACY.md). The SLAM failures of
/// failureScenarioNames() follow. Throws Error for another name.
SimParams scenario(const std::string& name, std::uint64_t seed, std::size_t map_points);

/// The names scenario() knows.
const std::vector<std::string>& scenarioNames();

/// The drives whose SLAM fails in ways the fusion does not model (SlamErrors), each with its
/// own clock offset: open_varying_drift (drift whose rate changes along the route),
/// loop_closures (three laps, a pose graph that snaps 0.5-3 m at each closure),
/// open_height_drift (height drifting by tens of metres), race_track (60-80 m/s, 10 Hz RTK),
/// urban_keyframes_1hz (keyframes every 1-3 m, stops, urban GNSS at 1 Hz without covariance,
/// stamps 0.47 s late), city_ins_10hz (GNSS/INS at 10 Hz, stamps 0.12 s early),
/// loop_unclosed (ends where it began, no loop closure), figure_eight (crosses itself on a
/// bridge).
const std::vector<std::string>& failureScenarioNames();

}  // namespace flexcloud::sim
