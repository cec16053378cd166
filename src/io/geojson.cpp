#include "flexcloud/io/geojson.h"

#include <nlohmann/json.hpp>

namespace flexcloud {
namespace {

using nlohmann::json;

/// [lon, lat, h] rounded to 1e-9 degrees (0.1 mm) and 0.1 mm.
json position(const EnuFrame& frame, const Eigen::Vector3d& enu) {
  const Datum g = frame.toGeodetic(enu);
  const auto round = [](double v, double unit) { return std::round(v / unit) * unit; };
  return json::array({round(g.lon, 1e-9), round(g.lat, 1e-9), round(g.alt, 1e-4)});
}

json line(const EnuFrame& frame, const std::string& name, const Trajectory& t) {
  json coordinates = json::array();
  for (const Pose& p : t) coordinates.push_back(position(frame, p.position));
  return {{"type", "Feature"},
          {"properties", {{"kind", "trajectory"}, {"name", name}, {"poses", t.size()}}},
          {"geometry", {{"type", "LineString"}, {"coordinates", coordinates}}}};
}

json point(const EnuFrame& frame, const Eigen::Vector3d& enu, json properties) {
  return {{"type", "Feature"},
          {"properties", std::move(properties)},
          {"geometry", {{"type", "Point"}, {"coordinates", position(frame, enu)}}}};
}

}  // namespace

std::string trajectoriesGeojson(const GeoreferenceResult& r) {
  if (!r.datum) throw Error("trajectories.geojson: the run has no datum (local GNSS)");
  const EnuFrame frame(*r.datum);
  json features = json::array();
  features.push_back(line(frame, "gnss", gnssTrajectory(r)));
  features.push_back(line(frame, "slam_aligned", r.aligned));
  if (r.fusion) features.push_back(line(frame, "fused", r.fusion->poses));
  features.push_back(line(frame, "corrected", r.rubbersheet));
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
