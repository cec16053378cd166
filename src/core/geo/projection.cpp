#include "flexcloud/geo/projection.h"

#include <GeographicLib/MGRS.hpp>
#include <GeographicLib/UTMUPS.hpp>
#include <cmath>
#include <sstream>

#include "flexcloud/types.h"

namespace flexcloud {
namespace {

constexpr double kSquare = 100000.0;  // an MGRS 100 km square

std::string describe(const Eigen::Vector3d& p) {
  std::ostringstream s;
  s.precision(3);
  s << std::fixed << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return s.str();
}

}  // namespace

const std::vector<std::string>& projectorNames() {
  static const std::vector<std::string> names = {"local_cartesian", "local_cartesian_utm", "mgrs"};
  return names;
}

ProjectorType parseProjector(const std::string& text) {
  const auto& n = projectorNames();
  for (std::size_t i = 0; i < n.size(); ++i) {
    if (text == n[i]) return static_cast<ProjectorType>(i);
  }
  throw Error("projector: '" + text + "' is not one of local_cartesian, local_cartesian_utm, mgrs");
}

std::string autowareProjectorType(ProjectorType type) {
  switch (type) {
    case ProjectorType::kLocalCartesian:
      return "LocalCartesian";
    case ProjectorType::kLocalCartesianUtm:
      return "LocalCartesianUTM";
    case ProjectorType::kMgrs:
      return "MGRS";
  }
  return "";
}

UtmZone utmZoneOf(const Datum& datum) {
  if (!isValidGeodetic(datum.lat, datum.lon, datum.alt) || datum.lat >= 84.0 || datum.lat < -80.0) {
    std::ostringstream s;
    s.precision(9);
    s << "datum latitude " << datum.lat
      << " is beyond the reach of UTM (80 S to 84 N); use the local_cartesian frame there";
    throw Error(s.str());
  }
  UtmZone z;
  z.zone = GeographicLib::UTMUPS::StandardZone(datum.lat, datum.lon);
  z.north = datum.lat >= 0.0;
  return z;
}

MapProjection::MapProjection(const Datum& datum, ProjectorType type)
    : datum_(datum), type_(type), local_(datum.lat, datum.lon, datum.alt) {
  requireValidGeodetic(datum, "datum");
  if (type == ProjectorType::kLocalCartesian) return;
  zone_ = utmZoneOf(datum);
  bool north = true;
  int zone = 0;
  GeographicLib::UTMUPS::Forward(datum.lat, datum.lon, zone, north, origin_x_, origin_y_,
                                 zone_.zone);
  square_x_ = std::floor(origin_x_ / kSquare) * kSquare;
  square_y_ = std::floor(origin_y_ / kSquare) * kSquare;
  if (type == ProjectorType::kMgrs) {
    GeographicLib::MGRS::Forward(zone_.zone, zone_.north, origin_x_, origin_y_, datum.lat, 0,
                                 mgrs_grid_);
  }
}

Eigen::Vector3d MapProjection::utmFromEnu(const Eigen::Vector3d& enu) const {
  return utmOf(geodeticOf(enu));
}

Datum MapProjection::geodeticOf(const Eigen::Vector3d& enu) const {
  Datum g;
  local_.Reverse(enu.x(), enu.y(), enu.z(), g.lat, g.lon, g.alt);
  return g;
}

Eigen::Vector3d MapProjection::utmOf(const Datum& g) const {
  int zone = 0;
  bool north = true;
  double x = 0.0, y = 0.0;
  try {
    GeographicLib::UTMUPS::Forward(g.lat, g.lon, zone, north, x, y, zone_.zone);
  } catch (const GeographicLib::GeographicErr& e) {
    throw Error("a point at latitude " + std::to_string(g.lat) + ", longitude " +
                std::to_string(g.lon) + " lies beyond the reach of UTM zone " +
                std::to_string(zone_.zone) + " (" + e.what() + ")");
  }
  // A point across the equator from the datum keeps the datum's hemisphere convention.
  if (north != zone_.north) y += zone_.north ? -10000000.0 : 10000000.0;
  return {x, y, g.alt};
}

Eigen::Vector3d MapProjection::enuFromUtm(const Eigen::Vector3d& utm) const {
  double lat = 0.0, lon = 0.0;
  GeographicLib::UTMUPS::Reverse(zone_.zone, zone_.north, utm.x(), utm.y(), lat, lon);
  Eigen::Vector3d enu;
  local_.Forward(lat, lon, utm.z(), enu.x(), enu.y(), enu.z());
  return enu;
}

Eigen::Vector3d MapProjection::fromEnu(const Eigen::Vector3d& enu) const {
  // Autoware's map_projection_loader takes the map origin's altitude as 0 for every projector
  // but MGRS: z is the ellipsoidal height. The ENU frame at the datum and the one at the same
  // latitude and longitude at height 0 share their axes (both on the datum's normal), so the
  // local Cartesian frame moves z alone.
  if (type_ == ProjectorType::kLocalCartesian) return {enu.x(), enu.y(), enu.z() + datum_.alt};
  if (type_ == ProjectorType::kLocalCartesianUtm) {
    const Eigen::Vector3d utm = utmFromEnu(enu);
    return {utm.x() - origin_x_, utm.y() - origin_y_, utm.z()};
  }
  const Datum g = geodeticOf(enu);
  const Eigen::Vector3d utm = utmOf(g);
  const Eigen::Vector3d in_square(utm.x() - square_x_, utm.y() - square_y_, utm.z());
  const bool inside = in_square.x() >= 0.0 && in_square.x() < kSquare && in_square.y() >= 0.0 &&
                      in_square.y() < kSquare &&
                      GeographicLib::UTMUPS::StandardZone(g.lat, g.lon) == zone_.zone;
  if (!inside) {
    throw Error("the map leaves the MGRS square " + mgrs_grid_ + " of the datum: ENU point " +
                describe(enu) + " lies in another square; use local_cartesian_utm");
  }
  return in_square;
}

}  // namespace flexcloud
