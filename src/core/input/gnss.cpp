#include "flexcloud/input/gnss.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace flexcloud {
namespace {

bool finiteStd(const Eigen::Vector3d& s) { return s.allFinite() && (s.array() >= 0.0).all(); }

/// Gives a fix with unknown covariance the default std-dev; false when it must be dropped. A
/// std-dev of exactly 0 on every axis means "not given" (no receiver is that good). With the
/// fusion, an unknown std-dev stays NaN: the fusion estimates it from the data.
bool resolveStd(Eigen::Vector3d& std_dev, const GnssOptions& options, GnssDropCounts& dropped) {
  if (std_dev.isZero(0.0)) std_dev.setConstant(std::nan(""));
  if (std_dev.hasNaN()) {
    if (options.default_std_dev <= 0.0 && options.estimate_unknown_std) {
      std_dev.setConstant(std::nan(""));
      return true;
    }
    if (options.default_std_dev <= 0.0) {
      ++dropped.unknown_covariance;
      return false;
    }
    std_dev.setConstant(options.default_std_dev);
  }
  if (!finiteStd(std_dev)) {
    ++dropped.invalid;
    return false;
  }
  return true;
}

/// True when a vehicle could move between the two points in the time between them.
bool reachable(const GnssPoint& a, const GnssPoint& b, double max_speed) {
  const double allowed =
      max_speed * std::abs(b.stamp - a.stamp) + 5.0 * (a.stdDev3d() + b.stdDev3d()) + 1.0;
  return (b.position - a.position).norm() <= allowed;
}

/// Drops the fixes of position jumps. The fixes are cut into segments wherever a step is
/// unreachable; each cut shifts the following segments by the jump (the step minus the motion
/// the previous step predicts). Segments whose shift agrees with the group of shifts that holds
/// the most fixes are kept: a receiver that jumps away and back, for one fix or for minutes,
/// loses exactly the fixes in between.
void dropJumps(PreparedGnss& out, double max_speed) {
  auto& pts = out.points;
  if (pts.size() < 2) return;
  std::vector<std::size_t> segment(pts.size(), 0);
  std::vector<Eigen::Vector3d> shift{Eigen::Vector3d::Zero()};
  std::vector<std::size_t> size{1};
  for (std::size_t i = 1; i < pts.size(); ++i) {
    if (reachable(pts[i - 1], pts[i], max_speed)) {
      segment[i] = segment[i - 1];
      ++size[segment[i]];
      continue;
    }
    Eigen::Vector3d predicted = Eigen::Vector3d::Zero();
    if (i >= 2 && segment[i - 2] == segment[i - 1]) {
      const double dt = pts[i - 1].stamp - pts[i - 2].stamp;
      if (dt > 0.0) {
        predicted =
            (pts[i - 1].position - pts[i - 2].position) * ((pts[i].stamp - pts[i - 1].stamp) / dt);
      }
    }
    shift.push_back(shift[segment[i - 1]] + (pts[i].position - pts[i - 1].position - predicted));
    size.push_back(1);
    segment[i] = shift.size() - 1;
  }
  if (shift.size() == 1) return;
  // The shift every segment is measured against: the one whose agreeing segments hold the most
  // fixes. Agreement: within the distance the vehicle could cover in a second, at least 10 m.
  const double agree = std::max(10.0, max_speed * 0.1);
  std::size_t best = 0, best_count = 0;
  for (std::size_t k = 0; k < shift.size(); ++k) {
    std::size_t count = 0;
    for (std::size_t j = 0; j < shift.size(); ++j) {
      if ((shift[j] - shift[k]).norm() <= agree) count += size[j];
    }
    if (count > best_count) best = k, best_count = count;
  }
  std::vector<GnssPoint> kept;
  kept.reserve(best_count);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if ((shift[segment[i]] - shift[best]).norm() <= agree) {
      kept.push_back(pts[i]);
    } else {
      ++out.dropped.outlier;
    }
  }
  pts.swap(kept);
}

/// Sorts by stamp, keeps the first of equal stamps, drops jumps.
void sortAndClean(PreparedGnss& out, const GnssOptions& options) {
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
  pts.swap(unique);
  if (options.drop_jumps) dropJumps(out, options.max_speed);
}

std::string dropSummary(const GnssDropCounts& d) {
  return "no fix " + std::to_string(d.no_fix) + ", invalid " + std::to_string(d.invalid) +
         ", unknown covariance " + std::to_string(d.unknown_covariance) + ", duplicate " +
         std::to_string(d.duplicate) + ", jump " + std::to_string(d.outlier);
}

void requireSome(const PreparedGnss& out) {
  if (out.received == 0) throw Error("GNSS: no fix given (an empty file, topic or bag)");
  if (out.points.empty()) {
    // Fixes without a covariance are dropped only without the fusion: say what keeps them.
    const std::string hint =
        out.dropped.unknown_covariance > 0
            ? "; fixes without a covariance need default_std_dev, or fusion true, which "
              "estimates their std-dev"
            : "";
    throw Error("GNSS: none of the " + std::to_string(out.received) + " fixes is usable (" +
                dropSummary(out.dropped) + ")" + hint);
  }
}

}  // namespace

PreparedGnss prepareGeodeticGnss(const std::vector<RawFix>& fixes, const GnssOptions& options) {
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
    if (!resolveStd(f.std_enu, options, out.dropped)) continue;
    valid.push_back(f);
  }
  if (valid.empty()) requireSome(out);
  if (options.datum) {
    out.datum = options.datum;
  } else {
    const auto first =
        std::min_element(valid.begin(), valid.end(),
                         [](const GeoFix& a, const GeoFix& b) { return a.stamp < b.stamp; });
    out.datum = Datum{first->lat, first->lon, first->alt};
  }
  const EnuFrame enu(*out.datum);
  out.points.reserve(valid.size());
  for (const auto& f : valid) {
    GnssPoint p;
    p.stamp = f.stamp + options.time_offset;
    p.position = enu.toEnu(f.lat, f.lon, f.alt);
    p.std_dev = f.std_enu;
    out.points.push_back(p);
  }
  sortAndClean(out, options);
  requireSome(out);
  if (!options.datum && out.points.front().position.norm() > 0.0) {
    // The earliest fix was dropped (a jump): the datum is the earliest fix that was kept.
    const EnuFrame now(enu.toGeodetic(out.points.front().position));
    for (auto& p : out.points) {
      const Datum g = enu.toGeodetic(p.position);
      p.position = now.toEnu(g.lat, g.lon, g.alt);
    }
    out.datum = now.datum();
  }
  return out;
}

PreparedGnss prepareLocalGnss(const std::vector<GnssPoint>& points, const GnssOptions& options) {
  PreparedGnss out;
  out.received = points.size();
  out.datum = options.datum;
  for (GnssPoint p : points) {
    if (!std::isfinite(p.stamp) || !p.position.allFinite() ||
        p.position.cwiseAbs().maxCoeff() > 1e8) {
      ++out.dropped.invalid;
      continue;
    }
    if (!resolveStd(p.std_dev, options, out.dropped)) continue;
    p.stamp += options.time_offset;
    out.points.push_back(p);
  }
  sortAndClean(out, options);
  requireSome(out);
  return out;
}

std::string droppedInWords(const GnssDropCounts& d) {
  std::string out;
  const auto add = [&](std::size_t n, const char* why) {
    if (n > 0) out += (out.empty() ? "" : ", ") + std::to_string(n) + " " + why;
  };
  add(d.no_fix, "with the receiver's status NO_FIX");
  add(d.invalid,
      "invalid (a stamp, coordinate or std-dev that is not a finite number, a negative std-dev, "
      "a latitude or longitude out of range)");
  add(d.unknown_covariance, "without a covariance (default_std_dev, or fusion true, keeps them)");
  add(d.duplicate, "with the stamp of an earlier fix");
  add(d.outlier, "in position jumps no vehicle could make (max_gnss_speed)");
  return out;
}

}  // namespace flexcloud
