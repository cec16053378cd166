#include "flexcloud/ros/frame_services.h"

#include "flexcloud/geo/frame_convert.h"

namespace flexcloud {
namespace {

/// Whether `frame` names the map frame (true) or the enu frame (false); Error otherwise.
bool isMapFrame(const NodeResult& r, const std::string& frame) {
  if (frame.empty() || frame == r.frames.map) return true;
  if (frame == r.frames.enu) return false;
  throw Error("frame '" + frame + "' is neither the map frame '" + r.frames.map +
              "' nor the enu frame '" + r.frames.enu + "'");
}

Eigen::Vector3d finitePoint(const geometry_msgs::Point& p, const std::string& what) {
  const Eigen::Vector3d v(p.x, p.y, p.z);
  if (!v.allFinite()) throw Error(what + " is not finite");
  return v;
}

}  // namespace

ToLL::Response toLL(const NodeResult& r, const ToLL::Request& req) {
  const Eigen::Vector3d p = finitePoint(req.map_point, "map_point");
  const bool in_map = isMapFrame(r, req.frame);
  const Eigen::Vector3d enu = in_map ? mapToEnu(r.result, p) : p;
  const Datum g = enuToGeodetic(r.result, enu);
  ToLL::Response res;
  if (in_map) res.message = coverageNote(r.result, p);
  res.ll_point.latitude = g.lat;
  res.ll_point.longitude = g.lon;
  res.ll_point.altitude = g.alt;
  res.success = true;
  return res;
}

FromLL::Response fromLL(const NodeResult& r, const FromLL::Request& req) {
  const Datum g{req.ll_point.latitude, req.ll_point.longitude, req.ll_point.altitude};
  const Eigen::Vector3d enu = geodeticToEnu(r.result, g);
  const Eigen::Vector3d p = isMapFrame(r, req.frame) ? enuToMap(r.result, enu) : enu;
  FromLL::Response res;
  res.map_point.x = p.x();
  res.map_point.y = p.y();
  res.map_point.z = p.z();
  res.success = true;
  return res;
}

ToEnu::Response toEnu(const NodeResult& r, const ToEnu::Request& req) {
  ToEnu::Response res;
  for (std::size_t i = 0; i < req.poses.size(); ++i) {
    const auto& in = req.poses[i];
    Pose p;
    p.position = finitePoint(in.position, "poses[" + std::to_string(i) + "].position");
    const auto& q = in.orientation;
    p.orientation = Eigen::Quaterniond(q.w, q.x, q.y, q.z);
    if (!p.orientation.coeffs().allFinite() || p.orientation.norm() < 1e-9) {
      p.orientation = Eigen::Quaterniond::Identity();  // a point: any orientation will do
    }
    p.orientation.normalize();
    const Pose e = mapPoseToEnu(r.result, p);
    geometry_msgs::Pose out;
    out.position.x = e.position.x();
    out.position.y = e.position.y();
    out.position.z = e.position.z();
    out.orientation.x = e.orientation.x();
    out.orientation.y = e.orientation.y();
    out.orientation.z = e.orientation.z();
    out.orientation.w = e.orientation.w();
    res.poses.push_back(out);
  }
  res.success = true;
  return res;
}

}  // namespace flexcloud
