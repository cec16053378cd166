#pragma once
// Warping a point cloud of any layout: only the x, y, z fields change, in place; every other
// field, the point order and the NaN points stay as they were.

#include <pcl/PCLPointCloud2.h>

#include <functional>

#include "flexcloud/cancel.h"
#include "flexcloud/metrics.h"
#include "flexcloud/rubber_sheet.h"

namespace flexcloud {

/// Where x, y and z sit in each point and whether they are float32 or float64.
struct XyzLayout {
  std::size_t offset[3] = {0, 0, 0};
  bool is_double[3] = {false, false, false};
  std::size_t point_step = 0;
  std::size_t points = 0;

  /// Reads the layout; throws Error naming `name` when x/y/z are missing, not FLOAT32/FLOAT64,
  /// outside the point, or the data size does not match points * point_step.
  static XyzLayout of(const std::vector<pcl::PCLPointField>& fields, std::size_t point_step,
                      std::size_t points, std::size_t data_size, const std::string& name);
  static XyzLayout of(const pcl::PCLPointCloud2& cloud, const std::string& name);
  Eigen::Vector3d get(const std::uint8_t* point) const;
  void set(std::uint8_t* point, const Eigen::Vector3d& p) const;
};

struct WarpStats {
  std::size_t points = 0;
  std::size_t outside = 0;     ///< beyond the cuboid: moved by the rigid transform, counted
  std::size_t non_finite = 0;  ///< NaN/inf points: kept as they are, in place
  /// Finite points before the warp (map frame), about 1000 evenly spread per call of
  /// warpPoints(): enough to judge where the map lies against its trajectory.
  std::vector<Eigen::Vector3d> sample;
};

/// Warps the xyz of every point with the rubber sheet (map frame -> ENU), on `threads` threads
/// (0: all cores). Throws Error("NAME: warp: cancelled") once `cancel` is cancelled (the
/// points are then partly warped).
WarpStats warpCloud(pcl::PCLPointCloud2& cloud, const RubberSheet& sheet, int threads,
                    const std::string& name = "map", const CancelToken& cancel = neverCancelled());
/// The same on a raw point buffer of the given layout.
WarpStats warpPoints(std::uint8_t* data, const XyzLayout& layout, const RubberSheet& sheet,
                     int threads, const std::string& name = "map",
                     const CancelToken& cancel = neverCancelled());

/// Deviation of the cloud's points, mapped by `f`, from the same points of `truth` (same count,
/// same order; NaN points skipped).
ErrorStats compareClouds(const pcl::PCLPointCloud2& cloud, const pcl::PCLPointCloud2& truth,
                         const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& f);

/// The same on point buffers: `n` points of `a` (mapped by `f`) against those of `b`, added to
/// `acc`.
void comparePoints(const std::uint8_t* a, const XyzLayout& la, const std::uint8_t* b,
                   const XyzLayout& lb, std::size_t n,
                   const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& f,
                   ErrorAccumulator& acc);

/// Number of worker threads for a request (0: hardware concurrency, at least 1).
int resolveThreads(int requested);

}  // namespace flexcloud
