#pragma once
// Choice of the control points: pairs of (SLAM position, GNSS position) spread along the drive.

#include <optional>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

struct ControlPoint {
  std::size_t pose_index = 0;  ///< index into the (prepared) trajectory
  double stamp = 0.0;
  Eigen::Vector3d source = Eigen::Vector3d::Zero();  ///< SLAM position, map frame (m)
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  ///< GNSS position, ENU frame (m)
  double std_dev = 0.0;                              ///< 3D GNSS std-dev (m)
};

struct ControlPointSelection {
  std::vector<ControlPoint> points;
  std::size_t requested = 0;
  std::size_t replaced = 0;  ///< nominal pose unusable, a neighbour in its stretch taken instead
  std::size_t skipped = 0;   ///< no usable pose in the whole stretch
  std::size_t merged = 0;    ///< same pose as another control point (more asked than poses)
  /// Beyond those asked for: where the sheet carried a pose more than 5 cm from its fused pose
  /// (buildFaithfulSheet(), with the fusion).
  std::size_t added = 0;
};

/// The numbers the choice of control points uses; controlPointOptions() (params.h) fills them
/// from the parameter table.
struct ControlPointOptions {
  int count = 0;                           ///< control points asked for on the trajectory
  double stddev_threshold = 0.0;           ///< m, the largest horizontal GNSS std-dev of one
  std::vector<TimeRange> excluded_ranges;  ///< pose stamps where none may lie
};

/// True when the GNSS at a pose may be a control point: matched, std-dev within the threshold,
/// outside every excluded time range.
bool isUsableGnss(const std::optional<GnssPoint>& gnss, double pose_stamp,
                  const ControlPointOptions& options);

/// options.count targets evenly spread by SLAM arc length from the first to the last
/// pose with GNSS (a standstill therefore gets one, not many). Each target takes the pose
/// nearest to it in arc length that is usable; the search stays within the target's stretch
/// (half the spacing each side). gnss[i] belongs to poses[i].
ControlPointSelection selectControlPoints(const Trajectory& poses,
                                          const std::vector<std::optional<GnssPoint>>& gnss,
                                          const ControlPointOptions& options);

/// Error-driven refinement: for each stretch between neighbouring control points (in pose
/// order, with the stretches before the first and after the last), the pose with the largest
/// deviation (m; NaN where the pose may not be a control point) that lies at least
/// min_separation metres of path (arc[i], m) from both control points of its stretch, so that
/// a standstill or a slow stretch never gathers control points. Returns the pose indices of the
/// `max_new` largest of these that exceed min_deviation, largest first.
std::vector<std::size_t> pickRefinements(const ControlPointSelection& selection,
                                         const std::vector<double>& deviation,
                                         const std::vector<double>& arc, double min_separation,
                                         std::size_t max_new, double min_deviation);

/// Appends the poses as control points and keeps the selection in pose order.
void addControlPoints(ControlPointSelection& selection, const std::vector<std::size_t>& poses,
                      const Trajectory& trajectory,
                      const std::vector<std::optional<GnssPoint>>& gnss);

}  // namespace flexcloud
