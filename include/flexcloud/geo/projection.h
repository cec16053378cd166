#pragma once
// Global frames for the georeferenced map: ENU points (about the datum) reprojected one by one
// through the ellipsoid into the frames Autoware and GIS tools use. Never an offset: the UTM grid
// turns against ENU by the meridian convergence and scales by up to 0.1 %.

#include <Eigen/Core>
#include <GeographicLib/LocalCartesian.hpp>
#include <string>
#include <vector>

#include "flexcloud/geo/geodesy.h"

namespace flexcloud {

/// The frame the points of an exported map are given in.
enum class ProjectorType {
  kLocalCartesian,     ///< ENU at the datum's latitude and longitude, z ellipsoidal height
  kLocalCartesianUtm,  ///< UTM (the datum's zone) minus the datum's UTM position; z = height
  kMgrs,               ///< easting/northing inside the datum's 100 km MGRS square; z = height
};

/// The names of the projector choice: local_cartesian, local_cartesian_utm, mgrs.
const std::vector<std::string>& projectorNames();
/// Throws Error naming the text when it is not one of projectorNames().
ProjectorType parseProjector(const std::string& text);
/// Autoware's projector_type for it: LocalCartesian, LocalCartesianUTM, MGRS.
std::string autowareProjectorType(ProjectorType type);

/// The UTM zone of a datum.
struct UtmZone {
  int zone = 0;
  bool north = true;
  /// EPSG code of WGS 84 / UTM in this zone: 326zz north, 327zz south.
  int epsg() const { return (north ? 32600 : 32700) + zone; }
};

/// The standard UTM zone of the datum; throws Error when UTM does not reach it (beyond 84 N or
/// 80 S, where UPS applies).
UtmZone utmZoneOf(const Datum& datum);

/// ENU (about the datum) -> the projector's frame, point by point; thread-safe.
class MapProjection {
 public:
  /// Throws Error when the projector needs UTM and the datum is beyond its reach.
  MapProjection(const Datum& datum, ProjectorType type);

  ProjectorType type() const { return type_; }
  /// The point in the projector's frame, z the ellipsoidal height for every projector (as
  /// Autoware reads it). Throws Error for MGRS when the point lies outside the datum's 100 km
  /// square (a map must stay in one square).
  Eigen::Vector3d fromEnu(const Eigen::Vector3d& enu) const;
  /// The point in the datum's UTM zone: easting, northing, ellipsoidal height (m).
  Eigen::Vector3d utmFromEnu(const Eigen::Vector3d& enu) const;
  /// The reverse of utmFromEnu.
  Eigen::Vector3d enuFromUtm(const Eigen::Vector3d& utm) const;
  /// The datum's 100 km MGRS square, e.g. "32UPU" (empty unless kMgrs).
  const std::string& mgrsGrid() const { return mgrs_grid_; }
  const UtmZone& zone() const { return zone_; }
  const Datum& datum() const { return datum_; }

 private:
  Datum geodeticOf(const Eigen::Vector3d& enu) const;
  Eigen::Vector3d utmOf(const Datum& geodetic) const;

  Datum datum_;
  ProjectorType type_;
  GeographicLib::LocalCartesian local_;
  UtmZone zone_;
  double origin_x_ = 0.0;  ///< the datum in UTM
  double origin_y_ = 0.0;
  double square_x_ = 0.0;  ///< south-west corner of the datum's MGRS square, UTM metres
  double square_y_ = 0.0;
  std::string mgrs_grid_;
};

}  // namespace flexcloud
