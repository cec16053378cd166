#include "flexcloud/geo/geodesy.h"

#include <cmath>
#include <sstream>

#include "flexcloud/types.h"

namespace flexcloud {

bool isValidGeodetic(double lat, double lon, double alt) {
  return std::isfinite(lat) && std::isfinite(lon) && std::isfinite(alt) && lat >= -90.0 &&
         lat <= 90.0 && lon >= -180.0 && lon <= 180.0 && alt >= -11000.0 && alt <= 100000.0;
}

void requireValidGeodetic(const Datum& g, const std::string& what) {
  if (isValidGeodetic(g.lat, g.lon, g.alt)) return;
  std::ostringstream s;
  s.precision(12);
  s << what << " (" << g.lat << ", " << g.lon << ", " << g.alt
    << ") is not a valid latitude/longitude/altitude";
  throw Error(s.str());
}

EnuFrame::EnuFrame(const Datum& datum) : datum_(datum) {
  requireValidGeodetic(datum, "datum");
  local_.Reset(datum.lat, datum.lon, datum.alt);
}

Eigen::Vector3d EnuFrame::toEnu(double lat, double lon, double alt) const {
  Eigen::Vector3d enu;
  local_.Forward(lat, lon, alt, enu.x(), enu.y(), enu.z());
  return enu;
}

Datum EnuFrame::toGeodetic(const Eigen::Vector3d& enu) const {
  Datum d;
  local_.Reverse(enu.x(), enu.y(), enu.z(), d.lat, d.lon, d.alt);
  return d;
}

}  // namespace flexcloud
