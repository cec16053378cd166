#pragma once
// The rubber sheet of a result: the enclosing cuboid, the control points on the trajectory
// (spread by arc length, then refined where the sheet deviates most from its targets), the
// points beside and above them, and the sheet itself. Private to the core.

#include <array>
#include <memory>
#include <optional>
#include <vector>

#include "flexcloud/sheet/beside_points.h"
#include "flexcloud/sheet/control_points.h"
#include "flexcloud/sheet/rubber_sheet.h"

namespace flexcloud {

using Cuboid = std::array<Eigen::Vector3d, 8>;

/// The numbers the sheet's construction uses; sheetOptions() fills them from the parameter
/// table (defined in params.cpp beside the other stages' options).
struct SheetOptions {
  ControlPointOptions control_points;  ///< the count asked for, std-dev threshold, excluded times
  double refine_fraction = 0.0;        ///< share placed by error-driven refinement
  double beside_distance = 0.0;        ///< m, points left and right of each control point
  double above_height = 0.0;           ///< m, a point above each control point
  Eigen::Vector3d margin = Eigen::Vector3d::Zero();  ///< cuboid margin, fraction of the extent
  double margin_min = 0.0;                           ///< m, the smallest margin on every axis
  /// The targets are measured fixes (not the fused trajectory): the refinement then follows
  /// where the sheet and the fixes part, not a lone fix off its neighbours.
  bool targets_are_fixes = false;
};
struct Params;
SheetOptions sheetOptions(const Params& p);

/// The corners of the axis-aligned box around the aligned trajectory and the targets, grown by
/// the margins.
Cuboid makeCuboid(const Trajectory& aligned, const std::vector<std::optional<GnssPoint>>& targets,
                  const SheetOptions& options);

/// The sheet through the control points, the extra point pairs and the cuboid corners (which
/// keep their rigidly aligned position). Triangulated in the aligned frame.
std::shared_ptr<const RubberSheet> buildSheet(const ControlPointSelection& cps,
                                              const std::vector<PointPair>& extra,
                                              const Eigen::Isometry3d& T_enu_map,
                                              const Cuboid& cuboid);
/// The targets of buildSheet()'s point pairs, in its order.
std::vector<Eigen::Vector3d> sheetTargets(const ControlPointSelection& cps,
                                          const std::vector<PointPair>& extra,
                                          const Cuboid& cuboid);

/// options.control_points.count control points on the trajectory: (1 - refine_fraction) of them
/// spread evenly by arc length over the poses with a target, the rest by error-driven
/// refinement against the targets (against the local consensus of the fixes where
/// options.targets_are_fixes). usable[i]: pose i may be a control point. Throws Error when
/// fewer than 4 are usable.
ControlPointSelection chooseControlPoints(const Trajectory& poses,
                                          const std::vector<std::optional<GnssPoint>>& targets,
                                          const std::vector<bool>& usable,
                                          const Eigen::Isometry3d& T_enu_map, const Cuboid& cuboid,
                                          const SheetOptions& options);

/// The sheet with points beside and above the control points at steady poses
/// (besidePoints()), its vertices fitted to the whole fused trajectory (sheet_fit.h); points
/// that fold the fitted sheet are left out, and the sheet built and fitted again, up to three
/// times.
struct SheetWithBeside {
  std::shared_ptr<const RubberSheet> sheet;
  std::vector<PointPair> beside;
  std::size_t folding = 0;  ///< beside points left out because they folded the sheet
  std::size_t added = 0;    ///< control points added where the sheet left the fused trajectory
};
SheetWithBeside buildSheetWithBeside(const ControlPointSelection& cps, const Trajectory& slam,
                                     const Trajectory& fused, const Eigen::Isometry3d& T_enu_map,
                                     const Cuboid& cuboid, const SheetOptions& options,
                                     const std::vector<bool>& steady);

/// buildSheetWithBeside(), then control points added (to `cps`) at the poses the sheet carries
/// far from their fused pose (beyond 5 cm and three times the typical deviation: a break, not
/// the sheet's resolution), the sheet built again, for a few rounds, more while every sheet so
/// far has folded (a pose a metre or more off): where the SLAM holds one place twice, apart (an
/// unclosed loop, a crossing), a pose between its own control points may lie in a tetrahedron
/// of the other pass, and only a control point of its own keeps it. Returns the sheet of the
/// round that carried no pose as far off as the others did, with its control points in `cps`.
/// `targets` and `usable` as for chooseControlPoints().
SheetWithBeside buildFaithfulSheet(ControlPointSelection& cps, const Trajectory& slam,
                                   const Trajectory& fused,
                                   const std::vector<std::optional<GnssPoint>>& targets,
                                   const std::vector<bool>& usable,
                                   const Eigen::Isometry3d& T_enu_map, const Cuboid& cuboid,
                                   const SheetOptions& options, const std::vector<bool>& steady);

}  // namespace flexcloud
