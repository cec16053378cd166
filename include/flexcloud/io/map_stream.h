#pragma once
// Warping a PCD map file of any encoding into a binary one chunk by chunk: memory stays at a
// few chunks whatever the map's size, and reading, warping and writing overlap.

#include <Eigen/Geometry>
#include <string>

#include "flexcloud/cancel.h"
#include "flexcloud/io/outputs.h"
#include "flexcloud/sheet/rubber_sheet.h"

namespace flexcloud {

class MapPrecopy;
class PointSigmaField;
class PoseCorrections;

struct MapStreamOptions {
  int threads = 0;  ///< warp threads; 0: all cores
  std::size_t chunk_points = 1 << 20;
  std::string truth;  ///< optional ground truth PCD: same points, same order
  Eigen::Isometry3d T_enu_map = Eigen::Isometry3d::Identity();  ///< for the rigid-only error
  /// Copy in the kernel and warp the copy in place, a chunk at a time, where the filesystem can
  /// reserve the space; false: always read, warp and write through buffers.
  bool in_place = true;
  /// The body's copy started at the run's start (taken over when it holds this map), or null.
  MapPrecopy* precopy = nullptr;
  /// Where set, every point gains sigma_h and sigma_v from it (point_sigma.h); the body is then
  /// read, warped and written through buffers.
  const PointSigmaField* point_sigma = nullptr;
  /// Where set, a map whose points name their pose (map_pose_field: "auto", "none" or a field's
  /// name; pointPoseField()) is rebuilt with these corrections instead of warped.
  const PoseCorrections* corrections = nullptr;
  std::string pose_field = "auto";
  /// Stops the warp (with Error) once cancelled; the output file is then not created.
  const CancelToken* cancel = &neverCancelled();
};

/// Warps PCD `in` (binary, ascii or binary_compressed) into binary PCD `out` (written under a
/// temporary name, renamed when complete) and fills info's warp counts, stage seconds and, with a
/// truth, its errors. Throws Error for a bad file, a truth of another size, a write failure or
/// cancellation.
void warpPcdFile(const std::string& in, const std::string& out, const RubberSheet& sheet,
                 const MapStreamOptions& options, MapInfo& info);

}  // namespace flexcloud
