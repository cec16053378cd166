#pragma once
// The georeferenced map as Autoware's map loaders take it: a folder of square PCD tiles with
// their metadata, and map_projector_info.yaml naming the frame of the points.

#include <cstddef>
#include <string>

#include "flexcloud/cancel.h"
#include "flexcloud/geo/projection.h"

namespace flexcloud {

struct AutowareOptions {
  double tile_size = 20.0;  ///< m, side of the square tiles (x and y of the projector's frame)
  ProjectorType projector = ProjectorType::kLocalCartesian;
  int threads = 0;  ///< reprojection threads; 0: all cores
  /// Points buffered per pass before the tiles are appended to (bounds the memory).
  std::size_t buffer_points = 4u << 20;
  const CancelToken* cancel = &neverCancelled();
};

struct AutowareSummary {
  std::size_t tiles = 0;
  std::size_t points = 0;      ///< points written into tiles
  std::size_t non_finite = 0;  ///< NaN/inf points: no place in any tile, counted, not written
  std::string mgrs_grid;       ///< with the MGRS projector
};

/// Tiles binary PCD `map_pcd` (ENU about `datum`, as georeference writes it) into
/// `dir`/pointcloud_map/ with `dir`/pointcloud_map_metadata.yaml and
/// `dir`/map_projector_info.yaml. Every finite point lands in exactly one tile with every field
/// kept; its x, y, z are reprojected into the projector's frame (ENU -> geodetic -> UTM/MGRS).
/// Streams the map twice (counting, then writing): memory stays near buffer_points points.
/// Throws Error for a bad tile size, a datum UTM cannot reach, a map that leaves its MGRS square,
/// a write failure or cancellation; `dir` is then incomplete and the caller discards it.
AutowareSummary writeAutowareMap(const std::string& map_pcd, const std::string& dir,
                                 const Datum& datum, const AutowareOptions& options);

/// map_projector_info.yaml for the projector.
std::string projectorInfoYaml(const MapProjection& projection);

}  // namespace flexcloud
