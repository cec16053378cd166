#pragma once
// The sheet fitted to the whole fused trajectory. A sheet through its control points is exact at
// them and linear in between, where the fused trajectory is not: the SLAM's errors between two
// control points bend it. The sheet's image of a point is linear in the targets of its
// tetrahedron's vertices, so the targets that carry every SLAM pose closest to its fused pose
// (least squares, a little ridge) follow from one sparse linear solve. Each control point and
// the points beside and above it move together (the rotation they carry is kept); the cuboid's
// corners stay. Private to the core.

#include <memory>
#include <vector>

#include "flexcloud/sheet/beside_points.h"
#include "flexcloud/sheet/control_points.h"
#include "flexcloud/sheet/rubber_sheet.h"
#include "flexcloud/types.h"
#include "sheet/sheet_builder.h"

namespace flexcloud {

/// The move (ENU, m) of each control point's target and of its points beside, in the order of
/// cps.points. `sheet` was built from cps, beside and then the cuboid corners (buildSheet());
/// poses are in the map frame, fused in ENU, one per pose. All zero where nothing is to fit.
std::vector<Eigen::Vector3d> fitSheetTargets(const RubberSheet& sheet,
                                             const ControlPointSelection& cps,
                                             const std::vector<PointPair>& beside,
                                             const Trajectory& poses, const Trajectory& fused);

/// `through` (built by buildSheet() from cps, beside and cuboid) with the control points and
/// their points beside moved by `move` (the cuboid as given): its tetrahedralization, retargeted.
std::shared_ptr<const RubberSheet> movedSheet(const RubberSheet& through, ControlPointSelection cps,
                                              std::vector<PointPair> beside,
                                              const std::vector<Eigen::Vector3d>& move,
                                              const Cuboid& cuboid);

}  // namespace flexcloud
