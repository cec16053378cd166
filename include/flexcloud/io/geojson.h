#pragma once
// The trajectories and control points of a run as GeoJSON (RFC 7946: WGS84 longitude, latitude,
// ellipsoidal height) for GIS tools.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "flexcloud/georeference.h"

namespace flexcloud {

/// A FeatureCollection: one LineString per trajectory (gnss, slam_aligned, fused with the
/// fusion, corrected), each control point and each rejected fix as a Point with its residuals.
/// Throws Error when the run has no datum (local GNSS without one: no place on the globe).
/// Lines that cross longitude 180 are cut there into the parts of a MultiLineString (RFC 7946,
/// 3.1.9), so GIS tools do not draw them around the globe.
std::string trajectoriesGeojson(const GeoreferenceResult& r);

/// A line of [lon, lat, h] (degrees, degrees, m) cut where it crosses the antimeridian: each
/// part ends at longitude +-180 and the next begins at -+180 with the latitude and height
/// interpolated at the crossing. One part when it never crosses.
std::vector<std::vector<Eigen::Vector3d>> cutAtAntimeridian(
    const std::vector<Eigen::Vector3d>& line);

}  // namespace flexcloud
