#include "flexcloud/io/geojson.h"

#include <cmath>
#include <nlohmann/json.hpp>

namespace flexcloud {
namespace {

using nlohmann::json;

/// [lon, lat, h] rounded to 1e-9 degrees (0.1 mm) and 0.1 mm.
json rounded(const Eigen::Vector3d& llh) {
  const auto round = [](double v, double unit) { return std::round(v / unit) * unit; };
  return json::array({round(llh.x(), 1e-9), round(llh.y(), 1e-9), round(llh.z(), 1e-4)});
}

Eigen::Vector3d lonLatHeight(const EnuFrame& frame, const Eigen::Vector3d& enu) {
  const Datum g = frame.toGeodetic(enu);
  return {g.lon, g.lat, g.alt};
}

json position(const EnuFrame& frame, const Eigen::Vector3d& enu) {
  return rounded(lonLatHeight(frame, enu));
}

json line(const EnuFrame& frame, const std::string& name, const Trajectory& t) {
  std::vector<Eigen::Vector3d> llh;
  llh.reserve(t.size());
  for (const Pose& p : t) llh.push_back(lonLatHeight(frame, p.position));
  json parts = json::array();
  for (const auto& part : cutAtAntimeridian(llh)) {
    json coordinates = json::array();
    for (const auto& q : part) coordinates.push_back(rounded(q));
    parts.push_back(std::move(coordinates));
  }
  const json geometry = parts.size() == 1
                            ? json{{"type", "LineString"}, {"coordinates", parts[0]}}
                            : json{{"type", "MultiLineString"}, {"coordinates", parts}};
  return {{"type", "Feature"},
          {"properties", {{"kind", "trajectory"}, {"name", name}, {"poses", t.size()}}},
          {"geometry", geometry}};
}

json point(const EnuFrame& frame, const Eigen::Vector3d& enu, json properties) {
  return {{"type", "Feature"},
          {"properties", std::move(properties)},
          {"geometry", {{"type", "Point"}, {"coordinates", position(frame, enu)}}}};
}

json finiteOrNull(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

/// How far the corrected trajectory may lie from the truth: per pose (in the order of its
/// poses; a vertex added where the line is cut at 180 degrees has none), 1-sigma per horizontal
/// axis and vertical, m, rounded to 0.1 mm; and their median and 95th percentile.
void withSigmas(const PoseSigmas& s, json& properties) {
  json h = json::array(), v = json::array();
  for (std::size_t i = 0; i < s.h.size(); ++i) {
    h.push_back(finiteOrNull(std::round(s.h[i] * 1e4) / 1e4));
    v.push_back(finiteOrNull(std::round(s.v[i] * 1e4) / 1e4));
  }
  properties["sigma_h_m"] = std::move(h);
  properties["sigma_v_m"] = std::move(v);
  properties["sigma_h_median_m"] = finiteOrNull(s.median_h);
  properties["sigma_h_p95_m"] = finiteOrNull(s.p95_h);
}

}  // namespace

std::vector<std::vector<Eigen::Vector3d>> cutAtAntimeridian(
    const std::vector<Eigen::Vector3d>& line) {
  std::vector<std::vector<Eigen::Vector3d>> parts(1);
  for (std::size_t i = 0; i < line.size(); ++i) {
    if (i > 0 && std::abs(line[i].x() - line[i - 1].x()) > 180.0) {
      const Eigen::Vector3d& a = line[i - 1];
      const double east = a.x() > 0.0 ? 180.0 : -180.0;  // the side a is on
      const double b_lon = line[i].x() + 2.0 * east;     // b unwrapped beyond a's side
      const double f = (east - a.x()) / (b_lon - a.x());
      const Eigen::Vector3d at = a + f * (Eigen::Vector3d(b_lon, line[i].y(), line[i].z()) - a);
      parts.back().emplace_back(east, at.y(), at.z());
      parts.emplace_back();
      parts.back().emplace_back(-east, at.y(), at.z());
    }
    parts.back().push_back(line[i]);
  }
  return parts;
}

std::string trajectoriesGeojson(const GeoreferenceResult& r) {
  if (!r.datum) throw Error("trajectories.geojson: the run has no datum (local GNSS)");
  const EnuFrame frame(*r.datum);
  json features = json::array();
  features.push_back(line(frame, "gnss", gnssTrajectory(r)));
  features.push_back(line(frame, "slam_aligned", r.aligned));
  if (r.fusion) features.push_back(line(frame, "fused", r.fusion->poses));
  features.push_back(line(frame, "corrected", r.rubbersheet));
  withSigmas(r.sigma, features.back()["properties"]);
  const auto& cps = r.control_points.points;
  for (std::size_t i = 0; i < cps.size(); ++i) {
    features.push_back(point(frame, cps[i].target,
                             {{"kind", "control_point"},
                              {"pose_index", cps[i].pose_index},
                              {"stamp", cps[i].stamp},
                              {"std_dev_m", cps[i].std_dev},
                              {"residual_aligned_m", r.residual_aligned[i]},
                              {"residual_rubbersheet_m", r.residual_rubbersheet[i]}}));
  }
  if (r.fusion) {
    for (const auto& f : r.fusion->fixes) {
      if (f.verdict != FixVerdict::kOutlier) continue;
      features.push_back(point(frame, f.position,
                               {{"kind", "rejected_fix"},
                                {"stamp", f.stamp},
                                {"reason", toString(f.verdict)},
                                {"residual_m", f.residual}}));
    }
  }
  return json{{"type", "FeatureCollection"}, {"features", features}}.dump() + "\n";
}

}  // namespace flexcloud
