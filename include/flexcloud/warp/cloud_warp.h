#pragma once
// Warping a point cloud of any layout: only the x, y, z fields change, in place; every other
// field, the point order and the NaN points stay as they were.

#include <cstring>
#include <functional>

#include "flexcloud/cancel.h"
#include "flexcloud/metrics.h"
#include "flexcloud/sheet/rubber_sheet.h"

namespace flexcloud {

/// Where x, y and z sit in each point and whether they are float32 or float64.
struct XyzLayout {
  std::size_t offset[3] = {0, 0, 0};
  bool is_double[3] = {false, false, false};
  std::size_t point_step = 0;
  std::size_t points = 0;

  // Read from a PCL cloud by xyzLayout() (flexcloud/io/cloud_layout.h).
  Eigen::Vector3d get(const std::uint8_t* point) const;
  void set(std::uint8_t* point, const Eigen::Vector3d& p) const;
};

class PointSigmaField;

/// Where the warp writes each point's sigmas (point_sigma.h): nothing where field is null.
/// Point i's sigma_h and sigma_v go to out + i * stride, float32 each: two floats a point of
/// their own, or into each point's row (out: the first row's sigma_h, stride: the row's bytes).
struct SigmaSink {
  const PointSigmaField* field = nullptr;
  std::uint8_t* out = nullptr;
  std::size_t stride = 2 * sizeof(float);

  /// Writes point i's sigma_h and sigma_v (nothing where field is null).
  void write(std::size_t i, float h, float v) const {
    if (field == nullptr) return;
    std::uint8_t* at = out + i * stride;
    std::memcpy(at, &h, sizeof(float));
    std::memcpy(at + sizeof(float), &v, sizeof(float));
  }
};

struct WarpStats {
  std::size_t points = 0;
  std::size_t outside = 0;     ///< beyond the cuboid: moved by the rigid transform, counted
  std::size_t non_finite = 0;  ///< NaN/inf points: kept as they are, in place
  /// Finite points before the warp (map frame), about 1000 evenly spread per call of
  /// warpPoints(): enough to judge where the map lies against its trajectory.
  std::vector<Eigen::Vector3d> sample;

  /// Adds the counts and the sample of another part of the map.
  void merge(const WarpStats& o) {
    points += o.points;
    outside += o.outside;
    non_finite += o.non_finite;
    sample.insert(sample.end(), o.sample.begin(), o.sample.end());
  }
};

/// About 1000 finite points of the n of a raw buffer, evenly spread (WarpStats::sample).
std::vector<Eigen::Vector3d> samplePoints(const std::uint8_t* data, const XyzLayout& layout);

/// Warps the xyz of every point of a raw buffer of the given layout with the rubber sheet (map
/// frame -> ENU), on `threads` threads (0: all cores). Throws Error("NAME: warp: cancelled")
/// once `cancel` is cancelled (the points are then partly warped). With `sigmas` set, each
/// point's sigma_h and sigma_v go where it says (NaN for a NaN point).
WarpStats warpPoints(std::uint8_t* data, const XyzLayout& layout, const RubberSheet& sheet,
                     int threads, const std::string& name = "map",
                     const CancelToken& cancel = neverCancelled(), const SigmaSink& sigmas = {});

/// Deviation of `n` points of `a` (mapped by `f`) from the same points of `b`, added to
/// `acc` (NaN points skipped).
void comparePoints(const std::uint8_t* a, const XyzLayout& la, const std::uint8_t* b,
                   const XyzLayout& lb, std::size_t n,
                   const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& f,
                   ErrorAccumulator& acc);

/// Number of worker threads for a request (0: hardware concurrency, at least 1).
int resolveThreads(int requested);

}  // namespace flexcloud
