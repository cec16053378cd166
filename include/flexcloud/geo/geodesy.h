#pragma once
// WGS84 <-> local East-North-Up about a datum, through GeographicLib. Doubles throughout.

#include <Eigen/Core>
#include <GeographicLib/LocalCartesian.hpp>
#include <string>

namespace flexcloud {

/// A datum on the WGS84 ellipsoid: latitude, longitude (deg) and ellipsoidal altitude (m).
struct Datum {
  double lat = 0.0;
  double lon = 0.0;
  double alt = 0.0;
};

/// The local ENU frame tangent to the ellipsoid at a datum.
class EnuFrame {
 public:
  /// Throws Error when the datum is not finite or out of range.
  explicit EnuFrame(const Datum& datum);

  /// ENU position (m) of a geodetic point (deg, deg, m).
  Eigen::Vector3d toEnu(double lat, double lon, double alt) const;
  /// Geodetic point (deg, deg, m) of an ENU position (m).
  Datum toGeodetic(const Eigen::Vector3d& enu) const;
  const Datum& datum() const { return datum_; }

 private:
  Datum datum_;
  GeographicLib::LocalCartesian local_;
};

/// True when lat in [-90, 90], lon in [-180, 180], alt in [-11 km, 100 km], all finite.
bool isValidGeodetic(double lat, double lon, double alt);
/// Throws Error "WHAT (lat, lon, alt) is not a valid latitude/longitude/altitude" unless valid.
void requireValidGeodetic(const Datum& g, const std::string& what);

}  // namespace flexcloud
