#pragma once
// PCL's clouds in the core's terms: the layout of x, y, z in a PCLPointCloud2 (or its fields),
// and the warp and truth comparison of a whole cloud in memory.

#include <pcl/PCLPointCloud2.h>

#include <functional>
#include <string>
#include <vector>

#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud {

/// One field of a point (count 1).
pcl::PCLPointField pointField(const std::string& name, std::uint32_t offset, std::uint8_t datatype);

/// Reads the layout; throws Error naming `name` when x/y/z are missing, not FLOAT32/FLOAT64,
/// outside the point, or the data size does not match points * point_step.
XyzLayout xyzLayout(const std::vector<pcl::PCLPointField>& fields, std::size_t point_step,
                    std::size_t points, std::size_t data_size, const std::string& name);
XyzLayout xyzLayout(const pcl::PCLPointCloud2& cloud, const std::string& name);

/// `fields` of points of `point_step` bytes with sigma_h and sigma_v (FLOAT32, m) appended after
/// them (widenPoints); throws Error naming `name` where they hold either already.
std::vector<pcl::PCLPointField> withSigmaFields(std::vector<pcl::PCLPointField> fields,
                                                std::size_t point_step, const std::string& name);

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
