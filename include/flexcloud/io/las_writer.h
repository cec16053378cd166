#pragma once
// The georeferenced map as LAS 1.4 for GIS tools (QGIS, PDAL, CloudCompare): UTM coordinates in
// the datum's zone with the CRS as OGC WKT from PROJ's database. No LAS library is packaged in
// Debian 12; this writer covers what flexcloud writes and nothing else.

#include <cstddef>
#include <string>

#include "flexcloud/cancel.h"
#include "flexcloud/geo/geodesy.h"

namespace flexcloud {

struct LasSummary {
  std::size_t points = 0;        ///< points written
  std::size_t non_finite = 0;    ///< NaN/inf points: LAS has no place for them, counted
  int epsg = 0;                  ///< WGS 84 / UTM zone of the datum
  int point_format = 6;          ///< 6, or 7 with rgb
  std::size_t extra_fields = 0;  ///< PCD fields kept as LAS extra bytes
};

/// OGC WKT (WKT1, as GDAL writes it) of an EPSG CRS, from PROJ's database. Throws Error when PROJ
/// does not know the code.
std::string wktOfEpsg(int epsg);

/// Writes binary PCD `map_pcd` (ENU about `datum`) as LAS 1.4 `las_path`: point format 6 (7 when
/// the map has rgb/rgba), x, y in the datum's UTM zone, z ellipsoidal height, scale 1 mm, offsets
/// at the datum rounded to 1 km; intensity into its field, every other field as extra bytes.
/// Streams the map; the header is completed at the end. Throws Error for a datum UTM cannot reach
/// (beyond 84 N or 80 S), a map that does not fit the 1 mm grid, a write failure or cancellation.
LasSummary writeLas(const std::string& map_pcd, const std::string& las_path, const Datum& datum,
                    int threads = 0, const CancelToken& cancel = neverCancelled());

}  // namespace flexcloud
