#pragma once
// The whole georeferencing pipeline on a drive: GNSS to ENU, keyframe interpolation, rigid
// alignment, control points, rubber sheet, warped trajectories and their metrics. The map is
// warped separately with the result (cloud_warp.h), so a retune never re-reads it.

#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "flexcloud/fusion/clock_offset.h"
#include "flexcloud/fusion/fusion.h"
#include "flexcloud/input/gnss.h"
#include "flexcloud/input/jitter_smoothing.h"
#include "flexcloud/input/trajectory.h"
#include "flexcloud/params.h"
#include "flexcloud/sheet/alignment.h"
#include "flexcloud/sheet/beside_points.h"
#include "flexcloud/sheet/control_points.h"
#include "flexcloud/sheet/rubber_sheet.h"
#include "flexcloud/uncertainty/map_sigma.h"
#include "flexcloud/uncertainty/pose_sigma.h"
#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud {

/// What one drive provides. Give geodetic fixes or local GNSS, not both.
struct DriveInput {
  std::vector<RawFix> fixes;
  std::vector<GnssPoint> local_gnss;
  Trajectory poses;
};

struct StageSeconds {
  double gnss = 0.0;
  double interpolation = 0.0;
  double alignment = 0.0;
  double fusion = 0.0;
  double control_points = 0.0;  ///< selection, refinement and the sheet
  double trajectory_warp = 0.0;
  double sigma = 0.0;  ///< the pose sigmas (pose_sigma.h)
};

/// The method whose control points made the sheet.
enum class Method {
  kFusion,  ///< the fused trajectory's
  kGnss,    ///< the GNSS at the poses' (the published method's way, with flexcloud's spread)
};

std::string toString(Method m);

/// Control points of different passes over the same place whose target offset (fused
/// trajectory, or GNSS without fusion) disagrees with their SLAM offset: the SLAM map holds that
/// place twice (an unclosed loop). One warp of space cannot put both passes right.
struct RevisitCheck {
  std::size_t pairs = 0;        ///< pairs within 5 m of each other, on passes 50 m of path apart
  std::size_t conflicting = 0;  ///< of those, the SLAM disagreeing by more than 0.5 m + 3 sigma
  double worst = 0.0;           ///< largest such disagreement, metres
  /// Pairs where the raw GNSS disagreed with a SLAM the fused trajectory confirms: the GNSS was
  /// wrong there and was outvoted.
  std::size_t gnss_conflicting = 0;
};

struct GeoreferenceResult {
  std::optional<Datum> datum;
  PreparedGnss gnss;
  PoseCounts pose_counts;
  Trajectory poses;  ///< prepared SLAM poses, map frame
  /// Interpolated GNSS per pose, ENU; with the fusion, at the instant of the pose (the estimated
  /// clock offset applied; stamps on the SLAM clock).
  std::vector<std::optional<GnssPoint>> gnss_at_pose;
  std::size_t poses_matched = 0;
  Eigen::Isometry3d T_enu_map = Eigen::Isometry3d::Identity();  ///< applied rigid transform
  double scale = 1.0;  ///< scale of the similarity fit (reported, not applied)
  /// The fused trajectory and the fate of every fix (with params.fusion).
  std::optional<FusionResult> fusion;
  /// Whose control points made the sheet: the fused trajectory's, or with fusion false the
  /// GNSS at the poses'.
  Method method = Method::kGnss;
  /// Set where the fusion found the std-dev threshold leaving fewer than a quarter of the
  /// fixes and weighed every fix by its std-dev instead: what it found (a warning).
  std::string threshold_lifted;
  /// The clock offset applied to the GNSS: SLAM clock minus GNSS clock, s (gnss_time_offset
  /// and the estimate on top of it: the fusion's, or without the fusion the speed profiles'),
  /// and its 1-sigma (NaN where not estimated).
  double clock_offset = 0.0;
  double clock_offset_sigma = std::numeric_limits<double>::quiet_NaN();
  /// Without the fusion (and max_time_offset > 0): the speed profiles' estimate of the offset on
  /// top of gnss_time_offset, applied where it is beyond its noise (clock_offset_sigma finite).
  std::optional<ClockOffsetEstimate> speed_clock;
  ControlPointSelection control_points;
  std::vector<PointPair> beside;   ///< control points beside and above the trajectory
  std::size_t beside_folding = 0;  ///< beside points left out because they folded the sheet
  std::array<Eigen::Vector3d, 8> cuboid_enu;  ///< cuboid corners, aligned (ENU) frame
  std::shared_ptr<const RubberSheet> sheet;   ///< maps map-frame points to ENU
  Trajectory aligned;                         ///< T_enu_map * poses
  Trajectory rubbersheet;                     ///< sheet(poses), orientations rotated too
  ErrorStats metrics_aligned;                 ///< deviation to the GNSS at matched poses
  ErrorStats metrics_rubbersheet;
  /// Deviation of the rubber-sheeted trajectory from the fused one (how closely the sheet
  /// carries the fusion; with params.fusion).
  ErrorStats metrics_fused;
  std::vector<double> residual_aligned;  ///< per control point, metres
  std::vector<double> residual_rubbersheet;
  RevisitCheck revisits;
  /// How far each pose of `rubbersheet` may lie from the truth (pose_sigma.h).
  PoseSigmas sigma;
  /// How far the map may lie from the truth by band of distance from the route, moved by the
  /// sheet or by each point's own pose (map_sigma.h, the point sigmas' model of the run).
  MapSigma map_sigma{};
  /// max_sigma_h of the run (m): a result none of whose poses is known within it is degraded.
  double max_sigma_h = 0.0;
  /// The SLAM's white jitter from pose to pose as measured, and the smoothing that took it out
  /// of `rubbersheet` and the fused trajectory (with params.smooth_jitter), and per pose what is
  /// left of it there (m, per horizontal axis; 0 where none is seen).
  JitterSmoothing jitter;
  std::vector<double> jitter_left;
  StageSeconds seconds;
};

/// Runs the pipeline. Throws Error (one line naming the input and the problem) when the params
/// are invalid, no GNSS or pose is usable, the two do not overlap in time, fewer than 4 control
/// points are usable, the triangulation is degenerate, or `cancel` is cancelled.
GeoreferenceResult georeference(const DriveInput& input, const Params& params,
                                const CancelToken& cancel = neverCancelled());

/// A line when the least certain stretch of the result may lie further from the truth than
/// `max_sigma_h` (1-sigma per horizontal axis; 0: never); "" otherwise.
std::string sigmaWarning(const PoseSigmas& s, double max_sigma_h);

/// A line when the control points placed on the trajectory fall short of those asked for by
/// more than 10 % (the request capped by the poses with usable GNSS); "" otherwise.
std::string controlPointShortfall(const ControlPointSelection& cp, std::size_t poses);

/// The share of the map's sampled points farther than `distance` (m) from every pose, in the map
/// frame: most of a map lies near the drive that made it.
double shareFarFromPoses(const GeoreferenceResult& r, const WarpStats& map, double distance);

/// Why the result cannot be right, one line each (none: it may be): more than four in five of
/// the fixes the fusion judged rejected; a rigid scale more than 5 % from 1 (beyond any SLAM's
/// scale error: the GNSS of another drive, or a map not in metres); no pose known within a
/// hundred times max_sigma_h (fixes that all claim a kilometre); with a map, more than half of
/// it farther than 50 m from every pose.
std::vector<std::string> degradedReasons(const GeoreferenceResult& r, const WarpStats* map,
                                         const std::string& map_frame);

/// Throws Error "the result cannot be right: ..." where degradedReasons() gives any, unless
/// params.accept_degraded.
void checkDegraded(const GeoreferenceResult& r, const Params& params, const WarpStats* map,
                   const std::string& map_frame);

/// The share of the poses with a sampled map point within `distance` (m): all of them where the
/// drive so far made part of the map (a bag still playing), few where the map is in another frame.
double sharePosesInMap(const GeoreferenceResult& r, const WarpStats& map, double distance);

/// What a user must read beside the result, one line each: a large share of the poses without
/// GNSS or of the map beyond the GNSS coverage (moved by the rigid transform only; `map` null:
/// no map), a lifted std-dev threshold, every degradedReasons() line as "degraded: ..." (a map
/// mostly far from its poses among them), control points short of those asked for, and revisit
/// conflicts.
std::vector<std::string> resultWarnings(const GeoreferenceResult& r, const Params& params,
                                        const WarpStats* map, const std::string& map_frame = "map");

/// The fixes the result rests on, at their instants on the SLAM clock: the fusion's inliers, or
/// without the fusion the fixes a control point may come from.
std::vector<SigmaFix> sigmaFixes(const GeoreferenceResult& r, const Params& params);

/// Where a clock offset was estimated and applied, the 1-sigma of the most precise profile that
/// told it (speed or heading), s; 0 where none was applied.
double estimatedClockSigma(const GeoreferenceResult& r);

/// The poses a map's points are rebuilt with (pose_rebuild.h), one per pose of `poses`: the
/// fused trajectory where the sheet was fitted to it, else the rubber-sheeted one.
const Trajectory& resultPoses(const GeoreferenceResult& r);

/// The interpolated GNSS at every matched pose, stamped like the pose (identity orientation).
Trajectory gnssTrajectory(const GeoreferenceResult& r);

/// The rotation the sheet applies around `at` (map frame): the rigid fit of six points 5 m
/// either side of it along the axes to their images. The points are located by a walk from the
/// tetrahedron `hint` (the one that holds `at`, or any): no grid is built for them.
Eigen::Matrix3d sheetRotationAt(const RubberSheet& sheet, const Eigen::Vector3d& at, int hint = 0);

/// A pose through the sheet: the position warped, the orientation turned by the sheet's
/// rotation around it (sheetRotationAt). `hint` carries the tetrahedron of the previous pose
/// (0 to start).
Pose warpPose(const RubberSheet& sheet, const Pose& p, int& hint);

}  // namespace flexcloud
