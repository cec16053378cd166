#pragma once
// Control points off the trajectory: the rubber sheet of positions along a road cannot see the
// rotation errors of the SLAM (heading, pitch, roll), which move points beside and above the
// road. For each control point on the trajectory, points at +-beside_distance and twice as far
// (left, right) and above_height (up) are added, mapped from the SLAM pose to the fused pose: the
// sheet then carries the rotation of the correction as well as its translation. Left and up are the
// body axes nearest to the body's own left and up (bodyAxes()): a body may drive along x (ROS), y
// (the KITTI odometry of kitti_lo) or z (a camera's frame).

#include <vector>

#include "flexcloud/sheet/control_points.h"
#include "flexcloud/sheet/rubber_sheet.h"
#include "flexcloud/types.h"

namespace flexcloud {

/// A point pair of the rubber sheet: source in the map frame, target in ENU.
struct PointPair {
  Eigen::Vector3d source = Eigen::Vector3d::Zero();
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  std::size_t pose_index = 0;  ///< the control point it belongs to
};

/// The points beside and above each control point. Where another part of the route lies nearer
/// to an offset point than 0.7 times its offset (another pass, the inside of a tight curve), the
/// point moves in, halving its offset, until none does (or is left out below 1.5 m): the space
/// between two passes is shared, each pass keeping its own correction up to near halfway, and
/// no place gets two targets. Control points at poses where `steady` is false (the SLAM
/// wrong from pose to pose there: its orientation at one pose says little of the map beside
/// it) get none; an empty `steady` holds everywhere.
std::vector<PointPair> besidePoints(const ControlPointSelection& cps, const Trajectory& slam,
                                    const Trajectory& fused, double beside, double above,
                                    const std::vector<bool>& steady = {});

/// Indices (into `pairs`) of the points that are vertices of tetrahedra the sheet turns inside
/// out or squeezes flat (determinant of the linear part below 0.2). The sheet's sources are
/// the pairs' sources moved by `input_to_source` (the frame the sheet triangulates in).
/// `vertex_arc` (may be empty) gives, per vertex of the sheet, the path (m) of the pose it
/// belongs to, NaN for none: a tetrahedron whose vertices belong to poses more than `pass_gap`
/// of path apart spans two passes that the SLAM put apart and the targets bring together
/// (an unclosed loop); it must fold, and keeps its points, which hold each pass's map to its
/// own correction.
std::vector<std::size_t> foldingPoints(const RubberSheet& sheet,
                                       const std::vector<PointPair>& pairs,
                                       const Eigen::Isometry3d& input_to_source,
                                       const std::vector<double>& vertex_arc = {},
                                       double pass_gap = 0.0);

}  // namespace flexcloud
