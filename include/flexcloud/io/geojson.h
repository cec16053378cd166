#pragma once
// The trajectories and control points of a run as GeoJSON (RFC 7946: WGS84 longitude, latitude,
// ellipsoidal height) for GIS tools.

#include <string>

#include "flexcloud/georeference.h"

namespace flexcloud {

/// A FeatureCollection: one LineString per trajectory (gnss, slam_aligned, fused with the
/// fusion, corrected), each control point and each rejected fix as a Point with its residuals.
/// Throws Error when the run has no datum (local GNSS without one: no place on the globe).
std::string trajectoriesGeojson(const GeoreferenceResult& r);

}  // namespace flexcloud
