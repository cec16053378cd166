#pragma once
// How far the map may lie from the truth, before any map is read: the point sigmas
// (point_sigma.h) of points at the sensor's height beside every pose, to its left and right,
// by band of distance from the route. The user reads the map's figure beside the trajectory's.

#include <array>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/sheet/rubber_sheet.h"
#include "flexcloud/uncertainty/point_sigma.h"
#include "flexcloud/uncertainty/pose_sigma.h"

namespace flexcloud {

/// Bands of horizontal distance from the route, m: 0-10, 10-30, 30-50.
constexpr int kMapSigmaBands = 3;
constexpr std::array<double, kMapSigmaBands + 1> kMapSigmaBandEdges = {0.0, 10.0, 30.0, 50.0};

/// The points' 1-sigma per horizontal axis (root mean square: the RMSE per axis expected;
/// median; 95th percentile) and vertical (root mean square) in one band, m; NaN where no pose
/// has a sigma.
struct MapSigmaBand {
  double h_rms, h_median, h_p95, v_rms;
};

/// The map's expected error by band, moved by the rubber sheet (a plain map) and by each point's
/// own pose (a map whose points name their pose).
struct MapSigma {
  std::array<MapSigmaBand, kMapSigmaBands> sheet, own_pose;
};

/// The expected error of a map made along `slam` (map frame) and moved to `result` (ENU) by
/// `sheet`, whose poses have `sigmas`: points at 4 distances a band, both sides, at a pose in
/// every stride that keeps about 1000 of them.
MapSigma expectedMapSigma(const Trajectory& slam, const Trajectory& result,
                          const PoseSigmas& sigmas, const RubberSheet& sheet,
                          const PointSigmaModel& model);

}  // namespace flexcloud
