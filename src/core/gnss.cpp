#include "flexcloud/gnss.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace flexcloud {
namespace {

bool finiteStd(const Eigen::Vector3d& s) { return s.allFinite() && (s.array() >= 0.0).all(); }

/// Gives a fix with unknown covariance the default std-dev; false when it must be dropped.
bool resolveStd(Eigen::Vector3d& std_dev, const Params& params, GnssDropCounts& dropped) {
  if (std_dev.hasNaN()) {
    if (params.default_std_dev <= 0.0) {
      ++dropped.unknown_covariance;
      return false;
    }
    std_dev.setConstant(params.default_std_dev);
  }
  if (!finiteStd(std_dev)) {
    ++dropped.invalid;
    return false;
  }
  return true;
}

/// True when a vehicle could move between the two points in the time between them.
bool reachable(const GnssPoint& a, const GnssPoint& b, double max_speed) {
  const double allowed = max_speed * std::abs(b.stamp - a.stamp) +
                         5.0 * (a.stdDev3d() + b.stdDev3d()) + 1.0;
  return (b.position - a.position).norm() <= allowed;
}

/// Sorts by stamp, keeps the first of equal stamps, drops single-fix jumps.
void sortAndClean(PreparedGnss& out, const Params& params) {
  auto& pts = out.points;
  std::stable_sort(pts.begin(), pts.end(),
                   [](const GnssPoint& a, const GnssPoint& b) { return a.stamp < b.stamp; });
  std::vector<GnssPoint> unique;
  unique.reserve(pts.size());
  for (const auto& p : pts) {
    if (!unique.empty() && p.stamp == unique.back().stamp) {
      ++out.dropped.duplicate;
      continue;
    }
    unique.push_back(p);
  }
  // A fix that no vehicle could reach from either neighbour is a jump of the receiver.
  std::vector<GnssPoint> kept;
  kept.reserve(unique.size());
  for (std::size_t i = 0; i < unique.size(); ++i) {
    const bool has_prev = i > 0;
    const bool has_next = i + 1 < unique.size();
    const bool bad_prev = has_prev && !reachable(unique[i - 1], unique[i], params.max_gnss_speed);
    const bool bad_next = has_next && !reachable(unique[i], unique[i + 1], params.max_gnss_speed);
    const bool isolated = (has_prev || has_next) && (!has_prev || bad_prev) && (!has_next || bad_next);
    if (isolated && (has_prev && has_next)) {
      ++out.dropped.outlier;
      continue;
    }
    kept.push_back(unique[i]);
  }
  pts.swap(kept);
}

std::string dropSummary(const GnssDropCounts& d) {
  return "no fix " + std::to_string(d.no_fix) + ", invalid " + std::to_string(d.invalid) +
         ", unknown covariance " + std::to_string(d.unknown_covariance) + ", duplicate " +
         std::to_string(d.duplicate) + ", jump " + std::to_string(d.outlier);
}

void requireSome(const PreparedGnss& out) {
  if (out.points.empty()) {
    throw Error("GNSS: none of the " + std::to_string(out.received) + " fixes is usable (" +
                dropSummary(out.dropped) + ")");
  }
}

}  // namespace

PreparedGnss prepareGeodeticGnss(const std::vector<RawFix>& fixes, const Params& params) {
  PreparedGnss out;
  out.received = fixes.size();
  std::vector<GeoFix> valid;
  valid.reserve(fixes.size());
  for (const auto& raw : fixes) {
    if (!raw.has_fix) {
      ++out.dropped.no_fix;
      continue;
    }
    GeoFix f = raw.fix;
    if (!std::isfinite(f.stamp) || !isValidGeodetic(f.lat, f.lon, f.alt)) {
      ++out.dropped.invalid;
      continue;
    }
    if (!resolveStd(f.std_enu, params, out.dropped)) continue;
    valid.push_back(f);
  }
  if (valid.empty()) requireSome(out);
  if (params.hasDatum()) {
    out.datum = Datum{params.datum_lat, params.datum_lon, params.datum_alt};
  } else {
    const auto first = std::min_element(valid.begin(), valid.end(),
                                        [](const GeoFix& a, const GeoFix& b) {
                                          return a.stamp < b.stamp;
                                        });
    out.datum = Datum{first->lat, first->lon, first->alt};
  }
  const EnuFrame enu(*out.datum);
  out.points.reserve(valid.size());
  for (const auto& f : valid) {
    GnssPoint p;
    p.stamp = f.stamp + params.gnss_time_offset;
    p.position = enu.toEnu(f.lat, f.lon, f.alt);
    p.std_dev = f.std_enu;
    out.points.push_back(p);
  }
  sortAndClean(out, params);
  requireSome(out);
  return out;
}

PreparedGnss prepareLocalGnss(const std::vector<GnssPoint>& points, const Params& params) {
  PreparedGnss out;
  out.received = points.size();
  if (params.hasDatum()) out.datum = Datum{params.datum_lat, params.datum_lon, params.datum_alt};
  for (GnssPoint p : points) {
    if (!std::isfinite(p.stamp) || !p.position.allFinite() ||
        p.position.cwiseAbs().maxCoeff() > 1e8) {
      ++out.dropped.invalid;
      continue;
    }
    if (!resolveStd(p.std_dev, params, out.dropped)) continue;
    p.stamp += params.gnss_time_offset;
    out.points.push_back(p);
  }
  sortAndClean(out, params);
  requireSome(out);
  return out;
}

}  // namespace flexcloud
