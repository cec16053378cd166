#pragma once
// Points and poses between the SLAM map frame, the ENU frame and WGS84 through a result's
// rubber sheet: what live data in the map frame needs, since the TF carries the rigid part only.

#include <Eigen/Geometry>
#include <string>

#include "flexcloud/georeference.h"

namespace flexcloud {

/// A map-frame position in ENU (through the rubber sheet).
Eigen::Vector3d mapToEnu(const GeoreferenceResult& r, const Eigen::Vector3d& map);
/// A map-frame pose in ENU: the position through the sheet, the orientation turned by the
/// rotation nearest to the sheet's local linear part.
Pose mapPoseToEnu(const GeoreferenceResult& r, const Pose& map);
/// The map-frame position the rubber sheet sends onto an ENU position. Throws Error with the
/// reason when no map point goes there, or two do (the sheet folds at that place).
Eigen::Vector3d enuToMap(const GeoreferenceResult& r, const Eigen::Vector3d& enu);

/// Where a map-frame position stands to the drive: "" inside the rubber sheet, else a note
/// that it got the rigid transform only, with its distance from the corrected trajectory.
std::string coverageNote(const GeoreferenceResult& r, const Eigen::Vector3d& map);

/// WGS84 of an ENU position; throws Error when the run has no datum.
Datum enuToGeodetic(const GeoreferenceResult& r, const Eigen::Vector3d& enu);
/// ENU of a WGS84 position; throws Error when the run has no datum or the position is invalid.
Eigen::Vector3d geodeticToEnu(const GeoreferenceResult& r, const Datum& geodetic);

}  // namespace flexcloud
