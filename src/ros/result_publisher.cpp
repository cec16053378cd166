#include "flexcloud/ros/result_publisher.h"

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Path.h>
#include <sensor_msgs/NavSatFix.h>
#include <visualization_msgs/MarkerArray.h>

#include "flexcloud/ros/conversions.h"
#include "flexcloud/ros/markers.h"

namespace flexcloud {

flexcloud::Result toResultMsg(const NodeResult* r, bool success, const std::string& message) {
  flexcloud::Result m;
  m.header.stamp = ros::Time::now();
  m.success = success;
  m.message = message;
  m.has_result = r != nullptr;
  if (r == nullptr) return m;
  const GeoreferenceResult& g = r->result;
  m.header.frame_id = r->frames.enu;
  m.warnings = r->warnings;
  m.sigma_h_median = g.sigma.median_h;
  m.sigma_h_p95 = g.sigma.p95_h;
  m.worst_from = g.sigma.worst.from;
  m.worst_to = g.sigma.worst.to;
  m.worst_sigma_h = g.sigma.worst.sigma_h;
  const auto& bands = r->map_info.pose_field.empty() ? g.map_sigma.sheet : g.map_sigma.own_pose;
  for (const MapSigmaBand& b : bands) {
    m.map_sigma_h_median.push_back(b.h_median);
    m.map_sigma_h_p95.push_back(b.h_p95);
  }
  m.method = toString(g.method);
  if (g.fusion && g.fusion->used + g.fusion->outliers > 0) {
    m.rejected_share = static_cast<double>(g.fusion->outliers) /
                       static_cast<double>(g.fusion->used + g.fusion->outliers);
  }
  m.lever_arm_source = r->lever_arm_source;
  m.fixes_used = static_cast<std::uint32_t>(g.gnss.points.size());
  m.fixes_dropped = static_cast<std::uint32_t>(g.gnss.dropped.total());
  if (g.fusion) {
    m.fixes_rejected = static_cast<std::uint32_t>(g.fusion->outliers);
    m.time_offset = g.fusion->time_offset;
    m.lever_arm.x = g.fusion->lever_arm.x();
    m.lever_arm.y = g.fusion->lever_arm.y();
    m.lever_arm.z = g.fusion->lever_arm.z();
    m.antenna_offset_estimated = g.fusion->antenna_offset_estimated;
    if (g.fusion->antenna_offset_estimated) {
      m.antenna_offset.x = g.fusion->antenna_offset.x();
      m.antenna_offset.y = g.fusion->antenna_offset.y();
    }
    m.estimated_std_h = g.fusion->estimated_std_h;
    m.estimated_std_v = g.fusion->estimated_std_v;
    m.slam_noise_scale = g.fusion->slam_noise_scale;
    m.slam_jitter_h = g.fusion->slam_jitter_h;
    m.slam_jitter_v = g.fusion->slam_jitter_v;
    m.poses_moved_to_fixes = static_cast<std::uint32_t>(g.fusion->detail_poses);
  } else if (g.speed_clock && std::isfinite(g.clock_offset_sigma)) {
    m.time_offset = g.speed_clock->offset;  // without the fusion, the speed profiles' offset
  }
  m.poses = static_cast<std::uint32_t>(g.poses.size());
  m.poses_matched = static_cast<std::uint32_t>(g.poses_matched);
  m.control_points = static_cast<std::uint32_t>(g.control_points.points.size());
  m.map_points = r->map_info.warp.points;
  m.points_outside = r->map_info.warp.outside;
  m.map_pose_field = r->map_info.pose_field;
  m.aligned = ros_conv::toDeviationMsg(g.metrics_aligned);
  m.rubbersheet = ros_conv::toDeviationMsg(g.metrics_rubbersheet);
  m.T_enu_map = ros_conv::toTransformMsg(g.T_enu_map);
  m.scale = g.scale;
  if (g.datum) {
    m.datum_lat = g.datum->lat;
    m.datum_lon = g.datum->lon;
    m.datum_alt = g.datum->alt;
  }
  m.seconds = r->seconds;
  for (const auto& row : nodeParamTable().rows()) {
    flexcloud::Parameter p;
    p.name = row.spec.name;
    p.value = formatValue(row.spec, row.get(r->params));
    m.parameters.push_back(p);
  }
  return m;
}

flexcloud::Georeference::Response toResponse(const flexcloud::Result& msg) {
  flexcloud::Georeference::Response res;
  res.success = msg.success;
  res.message = msg.message;
  if (!msg.success) return res;  // the numbers of an older result would mislead
  res.sigma_h_median = msg.sigma_h_median;
  res.sigma_h_p95 = msg.sigma_h_p95;
  res.worst_from = msg.worst_from;
  res.worst_to = msg.worst_to;
  res.worst_sigma_h = msg.worst_sigma_h;
  res.map_sigma_h_median = msg.map_sigma_h_median;
  res.map_sigma_h_p95 = msg.map_sigma_h_p95;
  res.method = msg.method;
  res.rejected_share = msg.rejected_share;
  res.warnings = msg.warnings;
  res.fixes_used = msg.fixes_used;
  res.fixes_dropped = msg.fixes_dropped;
  res.fixes_rejected = msg.fixes_rejected;
  res.time_offset = msg.time_offset;
  res.lever_arm = msg.lever_arm;
  res.lever_arm_source = msg.lever_arm_source;
  res.antenna_offset_estimated = msg.antenna_offset_estimated;
  res.antenna_offset = msg.antenna_offset;
  res.estimated_std_h = msg.estimated_std_h;
  res.estimated_std_v = msg.estimated_std_v;
  res.slam_noise_scale = msg.slam_noise_scale;
  res.slam_jitter_h = msg.slam_jitter_h;
  res.slam_jitter_v = msg.slam_jitter_v;
  res.poses_moved_to_fixes = msg.poses_moved_to_fixes;
  res.poses = msg.poses;
  res.poses_matched = msg.poses_matched;
  res.control_points = msg.control_points;
  res.map_points = msg.map_points;
  res.points_outside = msg.points_outside;
  res.map_pose_field = msg.map_pose_field;
  res.aligned = msg.aligned;
  res.rubbersheet = msg.rubbersheet;
  res.T_enu_map = msg.T_enu_map;
  res.scale = msg.scale;
  res.datum_lat = msg.datum_lat;
  res.datum_lon = msg.datum_lon;
  res.datum_alt = msg.datum_alt;
  res.seconds = msg.seconds;
  return res;
}

ResultPublisher::ResultPublisher(ros::NodeHandle& pnh) {
  using visualization_msgs::MarkerArray;
  map_ = pnh.advertise<sensor_msgs::PointCloud2>("global_map", 1, true);
  origin_ = pnh.advertise<sensor_msgs::NavSatFix>("origin", 1, true);
  path_gnss_ = pnh.advertise<nav_msgs::Path>("path_gnss", 1, true);
  path_slam_ = pnh.advertise<nav_msgs::Path>("path_slam", 1, true);
  path_aligned_ = pnh.advertise<nav_msgs::Path>("path_aligned", 1, true);
  path_sheet_ = pnh.advertise<nav_msgs::Path>("path_rubbersheet", 1, true);
  control_points_ = pnh.advertise<MarkerArray>("control_points", 1, true);
  tetrahedra_ = pnh.advertise<MarkerArray>("tetrahedra", 1, true);
  deviation_ = pnh.advertise<MarkerArray>("deviation", 1, true);
  sigma_ = pnh.advertise<MarkerArray>("sigma", 1, true);
  rejected_ = pnh.advertise<MarkerArray>("rejected_fixes", 1, true);
  result_ = pnh.advertise<flexcloud::Result>("result", 1, true);
}

geometry_msgs::TransformStamped viewFrame(const Trajectory& corrected, const std::string& enu,
                                          const ros::Time& stamp) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& p : corrected) {
    lo = lo.cwiseMin(p.position);
    hi = hi.cwiseMax(p.position);
  }
  const Eigen::Vector3d centre =
      corrected.empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d((lo + hi) / 2.0);
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = stamp;
  tf.header.frame_id = enu;
  tf.child_frame_id = enu + "_view";
  tf.transform = ros_conv::toTransformMsg(Eigen::Isometry3d(Eigen::Translation3d(centre)));
  return tf;
}

void ResultPublisher::show(const NodeResult& s) {
  const auto& r = s.result;
  const ros::Time now = ros::Time::now();
  const std::string& enu = s.frames.enu;
  if (s.map) map_.publish(s.map);
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = now;
  tf.header.frame_id = enu;
  tf.child_frame_id = s.frames.map;
  tf.transform = ros_conv::toTransformMsg(r.T_enu_map);
  tf_.sendTransform(tf);
  tf_.sendTransform(viewFrame(r.rubbersheet, enu, now));
  if (r.datum) {
    RawFix origin;
    origin.fix = GeoFix{now.toSec(), r.datum->lat, r.datum->lon, r.datum->alt,
                        Eigen::Vector3d::Constant(std::nan(""))};
    origin_.publish(ros_conv::toNavSatFix(origin, enu));
  }
  path_gnss_.publish(ros_conv::toPath(gnssTrajectory(r), enu));
  path_slam_.publish(ros_conv::toPath(r.poses, s.frames.map));
  path_aligned_.publish(ros_conv::toPath(r.aligned, enu));
  path_sheet_.publish(ros_conv::toPath(r.rubbersheet, enu));
  control_points_.publish(markers::controlPoints(r, enu, now));
  tetrahedra_.publish(markers::tetrahedra(r, enu, now));
  deviation_.publish(markers::deviation(r, enu, now));
  sigma_.publish(markers::sigma(r, enu, now, s.params.core.max_sigma_h));
  rejected_.publish(markers::rejectedFixes(r, enu, now));
}

void ResultPublisher::withdraw(const FrameNames& frames) {
  sensor_msgs::PointCloud2 empty;
  empty.header.stamp = ros::Time::now();
  empty.header.frame_id = frames.enu;
  map_.publish(empty);
  nav_msgs::Path none;
  none.header = empty.header;
  for (auto* p : {&path_gnss_, &path_aligned_, &path_sheet_}) p->publish(none);
  none.header.frame_id = frames.map;
  path_slam_.publish(none);
  for (auto* p : {&control_points_, &tetrahedra_, &deviation_, &sigma_, &rejected_}) {
    p->publish(markers::cleared(frames.enu));
  }
}

void ResultPublisher::report(const flexcloud::Result& msg) { result_.publish(msg); }

}  // namespace flexcloud
