#pragma once
// PCL's clouds in the core's terms: the layout of x, y, z in a PCLPointCloud2 (or its fields),
// and the warp and truth comparison of a whole cloud in memory.

#include <pcl/PCLPointCloud2.h>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "flexcloud/warp/cloud_warp.h"
#include "flexcloud/warp/pose_rebuild.h"

namespace flexcloud {

/// One field of a point (count 1).
pcl::PCLPointField pointField(const std::string& name, std::uint32_t offset, std::uint8_t datatype);

/// Whether two clouds' fields are the same: names, offsets, types and counts, in order.
bool sameFields(const std::vector<pcl::PCLPointField>& a, const std::vector<pcl::PCLPointField>& b);

/// Reads the layout; throws Error naming `name` when x/y/z are missing, not FLOAT32/FLOAT64,
/// outside the point, or the data size does not match points * point_step.
XyzLayout xyzLayout(const std::vector<pcl::PCLPointField>& fields, std::size_t point_step,
                    std::size_t points, std::size_t data_size, const std::string& name);
XyzLayout xyzLayout(const pcl::PCLPointCloud2& cloud, const std::string& name);

/// `fields` of points of `point_step` bytes with sigma_h and sigma_v (FLOAT32, m) appended after
/// them (widenPoints); throws Error naming `name` where they hold either already.
std::vector<pcl::PCLPointField> withSigmaFields(std::vector<pcl::PCLPointField> fields,
                                                std::size_t point_step, const std::string& name);

/// The field that names each point's pose (pose_rebuild.h), by `wanted`: "auto" takes the first
/// float64 field named time, timestamp, gps_time or t (a time on the odometry's clock) or integer
/// field named scan_index, scan_id, scan or keyframe (the pose's index); "none" takes none; any
/// other value names the field (float64: a time, an integer: an index). Empty where none is
/// taken; throws Error naming `name` where the named field is missing or of another type.
std::optional<PointPoseField> pointPoseField(const std::vector<pcl::PCLPointField>& fields,
                                             const std::string& wanted, const std::string& name);

/// How a map's points are moved: rebuilt, each with its own pose's correction, or (no rebuild)
/// by the rubber sheet; `note` says why a field that was found is not used.
struct MapMotion {
  std::optional<PoseRebuild> rebuild;
  std::string note;
};

/// Picks how to move a map of `fields`: rebuilt with `corrections` where pointPoseField() takes
/// a field and `sample` (the field's values over a spread of points) names their poses. A
/// field found by "auto" whose values name no pose leaves the sheet with a note; one named by
/// `wanted` throws Error naming `name` and the values.
MapMotion mapMotion(const std::vector<pcl::PCLPointField>& fields, const std::string& wanted,
                    const PoseCorrections& corrections,
                    const std::function<std::vector<double>(const PointPoseField&)>& sample,
                    const std::string& name);

/// Warps the xyz of every point with the rubber sheet (map frame -> ENU), on `threads` threads
/// (0: all cores). Throws Error("NAME: warp: cancelled") once `cancel` is cancelled (the
/// points are then partly warped).
WarpStats warpCloud(pcl::PCLPointCloud2& cloud, const RubberSheet& sheet, int threads,
                    const std::string& name = "map", const CancelToken& cancel = neverCancelled());

/// Deviation of the cloud's points, mapped by `f`, from the same points of `truth` (same count,
/// same order; NaN points skipped).
ErrorStats compareClouds(const pcl::PCLPointCloud2& cloud, const pcl::PCLPointCloud2& truth,
                         const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& f);

}  // namespace flexcloud
