#include "flexcloud/geo/frame_convert.h"

#include <Eigen/LU>
#include <algorithm>
#include <cstdio>
#include <limits>
#include <sstream>

namespace flexcloud {
namespace {

constexpr double kRoundTrip = 1e-6;  // m: an inverse must map back this closely

std::string describe(const Eigen::Vector3d& p) {
  std::ostringstream s;
  s.precision(3);
  s << std::fixed << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return s.str();
}

const RubberSheet& sheetOf(const GeoreferenceResult& r) {
  if (!r.sheet) throw Error("no georeferencing result yet");
  return *r.sheet;
}

const EnuFrame frameOf(const GeoreferenceResult& r) {
  if (!r.datum) throw Error("the result has no datum (the GNSS came in local coordinates)");
  return EnuFrame(*r.datum);
}

/// Barycentric coordinates of q in the tetrahedron a, b, c, d (all >= 0 inside).
Eigen::Vector4d barycentric(const Eigen::Vector3d& q, const Eigen::Vector3d& a,
                            const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                            const Eigen::Vector3d& d) {
  Eigen::Matrix3d m;
  m << b - a, c - a, d - a;
  const Eigen::Vector3d l = m.fullPivLu().solve(q - a);
  return {1.0 - l.sum(), l.x(), l.y(), l.z()};
}

/// The map point `a` sends onto enu, if `a` is invertible and the sheet agrees.
bool invertAt(const RubberSheet& sheet, const Affine34& a, const Eigen::Vector3d& enu,
              Eigen::Vector3d& map) {
  const Eigen::Matrix3d linear = a.leftCols<3>();
  if (std::abs(linear.determinant()) < 1e-12) return false;
  map = linear.inverse() * (enu - a.col(3));
  return (sheet.transform(map) - enu).norm() < kRoundTrip;
}

}  // namespace

Eigen::Vector3d mapToEnu(const GeoreferenceResult& r, const Eigen::Vector3d& map) {
  return sheetOf(r).transform(map);
}

std::string coverageNote(const GeoreferenceResult& r, const Eigen::Vector3d& map) {
  bool outside = false;
  const Eigen::Vector3d enu = sheetOf(r).transformReference(map, &outside);
  if (!outside) return "";
  double nearest = std::numeric_limits<double>::infinity();
  for (const auto& p : r.rubbersheet) nearest = std::min(nearest, (p.position - enu).norm());
  char buf[160];
  std::snprintf(buf, sizeof(buf),
                "the point lies beyond the rubber sheet, %.1f km from the drive: it got the "
                "rigid transform only, without drift correction",
                nearest / 1000.0);
  return buf;
}

Pose mapPoseToEnu(const GeoreferenceResult& r, const Pose& map) {
  int hint = 0;
  return warpPose(sheetOf(r), map, hint);
}

Eigen::Vector3d enuToMap(const GeoreferenceResult& r, const Eigen::Vector3d& enu) {
  const RubberSheet& sheet = sheetOf(r);
  const auto& t = sheet.targets();
  std::vector<Eigen::Vector3d> found;
  for (std::size_t k = 0; k < sheet.numTetrahedra(); ++k) {
    const auto& v = sheet.tetrahedra()[k];
    const Eigen::Vector4d l = barycentric(enu, t[v[0]], t[v[1]], t[v[2]], t[v[3]]);
    if (l.minCoeff() < -1e-9) continue;
    Eigen::Vector3d map;
    const RubberSheet::Location loc{static_cast<int>(k), false};
    if (invertAt(sheet, sheet.affineAt(loc), enu, map)) {
      const bool same = !found.empty() && (found.back() - map).norm() < 1e-3;
      if (!same) found.push_back(map);
    }
  }
  Eigen::Vector3d beyond;
  if (found.empty() && invertAt(sheet, sheet.outsideTransform(), enu, beyond)) {
    found.push_back(beyond);
  }
  if (found.size() == 1) return found.front();
  throw Error("ENU point " + describe(enu) +
              (found.empty() ? ": no map point is warped onto it (the sheet cannot be inverted "
                               "there)"
                             : ": the sheet folds there (several map points are warped onto it)"));
}

Datum enuToGeodetic(const GeoreferenceResult& r, const Eigen::Vector3d& enu) {
  return frameOf(r).toGeodetic(enu);
}

Eigen::Vector3d geodeticToEnu(const GeoreferenceResult& r, const Datum& g) {
  requireValidGeodetic(g, "position");
  return frameOf(r).toEnu(g.lat, g.lon, g.alt);
}

}  // namespace flexcloud
