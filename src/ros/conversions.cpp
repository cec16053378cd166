#include "flexcloud/ros/conversions.h"

#include <pcl_conversions/pcl_conversions.h>

#include <cmath>

#include "flexcloud/io/cloud_layout.h"

namespace flexcloud::ros_conv {

RawFix fromNavSatFix(const sensor_msgs::NavSatFix& msg) {
  RawFix f;
  f.has_fix = msg.status.status != sensor_msgs::NavSatStatus::STATUS_NO_FIX;
  f.fix.stamp = msg.header.stamp.toSec();
  f.fix.lat = msg.latitude;
  f.fix.lon = msg.longitude;
  f.fix.alt = msg.altitude;
  const auto& c = msg.position_covariance;
  const bool unknown =
      msg.position_covariance_type == sensor_msgs::NavSatFix::COVARIANCE_TYPE_UNKNOWN;
  const bool all_zero = c[0] == 0.0 && c[4] == 0.0 && c[8] == 0.0;
  if (unknown || all_zero) {
    f.fix.std_enu.setConstant(std::nan(""));
  } else {
    // A negative or non-finite variance stays invalid (-1): the pipeline counts and drops it.
    auto root = [](double v) { return std::isfinite(v) && v >= 0.0 ? std::sqrt(v) : -1.0; };
    f.fix.std_enu = Eigen::Vector3d(root(c[0]), root(c[4]), root(c[8]));
  }
  return f;
}

Pose fromPose(const ros::Time& stamp, const geometry_msgs::Pose& pose) {
  Pose p;
  p.stamp = stamp.toSec();
  p.position = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  p.orientation.coeffs() << pose.orientation.x, pose.orientation.y, pose.orientation.z,
      pose.orientation.w;
  return p;
}

Pose fromOdometry(const nav_msgs::Odometry& msg) {
  return fromPose(msg.header.stamp, msg.pose.pose);
}

Pose fromPoseStamped(const geometry_msgs::PoseStamped& msg) {
  return fromPose(msg.header.stamp, msg.pose);
}

Trajectory fromPath(const nav_msgs::Path& msg) {
  Trajectory out;
  out.reserve(msg.poses.size());
  for (const auto& p : msg.poses) out.push_back(fromPoseStamped(p));
  return out;
}

ros::Time toTime(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0 || seconds > 4294967295.0) {
    throw Error("stamp " + std::to_string(seconds) + " s cannot be a ROS time");
  }
  return ros::Time(seconds);
}

sensor_msgs::NavSatFix toNavSatFix(const RawFix& fix, const std::string& frame_id) {
  sensor_msgs::NavSatFix m;
  m.header.stamp = toTime(fix.fix.stamp);
  m.header.frame_id = frame_id;
  m.status.status = fix.has_fix ? sensor_msgs::NavSatStatus::STATUS_FIX
                                : sensor_msgs::NavSatStatus::STATUS_NO_FIX;
  m.status.service = sensor_msgs::NavSatStatus::SERVICE_GPS;
  m.latitude = fix.fix.lat;
  m.longitude = fix.fix.lon;
  m.altitude = fix.fix.alt;
  if (fix.fix.std_enu.allFinite()) {
    m.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_DIAGONAL_KNOWN;
    for (int a = 0; a < 3; ++a)
      m.position_covariance[4 * a] = fix.fix.std_enu(a) * fix.fix.std_enu(a);
  } else {
    m.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_UNKNOWN;
  }
  return m;
}

geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& t) {
  geometry_msgs::Pose m;
  m.position.x = t.translation().x();
  m.position.y = t.translation().y();
  m.position.z = t.translation().z();
  const Eigen::Quaterniond q(t.linear());
  m.orientation.x = q.x();
  m.orientation.y = q.y();
  m.orientation.z = q.z();
  m.orientation.w = q.w();
  return m;
}

geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& t) {
  const geometry_msgs::Pose pose = toPoseMsg(t);
  geometry_msgs::Transform m;
  m.translation.x = pose.position.x;
  m.translation.y = pose.position.y;
  m.translation.z = pose.position.z;
  m.rotation = pose.orientation;
  return m;
}

flexcloud::Deviation toDeviationMsg(const ErrorStats& s) {
  flexcloud::Deviation d;
  d.mae = s.mae;
  d.std = s.std;
  d.max = s.max;
  d.rmse = s.rmse;
  d.count = static_cast<std::uint32_t>(s.count);
  return d;
}

nav_msgs::Odometry toOdometry(const Pose& pose, const std::string& frame_id,
                              const std::string& child_frame_id) {
  nav_msgs::Odometry m;
  m.header.stamp = toTime(pose.stamp);
  m.header.frame_id = frame_id;
  m.child_frame_id = child_frame_id;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = pose.orientation.normalized().toRotationMatrix();
  t.translation() = pose.position;
  m.pose.pose = toPoseMsg(t);
  return m;
}

nav_msgs::Path toPath(const Trajectory& poses, const std::string& frame_id) {
  nav_msgs::Path m;
  m.header.frame_id = frame_id;
  m.poses.reserve(poses.size());
  for (const auto& p : poses) {
    geometry_msgs::PoseStamped ps;
    ps.header.frame_id = frame_id;
    ps.header.stamp = toTime(p.stamp);
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = p.orientation.normalized().toRotationMatrix();
    t.translation() = p.position;
    ps.pose = toPoseMsg(t);
    m.poses.push_back(ps);
  }
  if (!poses.empty()) m.header.stamp = m.poses.back().header.stamp;
  return m;
}

void toCloudMsg(const pcl::PCLPointCloud2& cloud, const std::string& frame_id,
                sensor_msgs::PointCloud2& msg) {
  pcl_conversions::fromPCL(cloud, msg);
  msg.header.frame_id = frame_id;
}

void fromCloudMsg(const sensor_msgs::PointCloud2& msg, pcl::PCLPointCloud2& cloud) {
  pcl_conversions::toPCL(msg, cloud);
}

std::vector<pcl::PCLPointField> pclFields(const sensor_msgs::PointCloud2& msg) {
  std::vector<pcl::PCLPointField> fields;
  pcl_conversions::toPCL(msg.fields, fields);
  return fields;
}

XyzLayout xyzLayout(const sensor_msgs::PointCloud2& msg, const std::string& name) {
  return flexcloud::xyzLayout(pclFields(msg), msg.point_step,
                              static_cast<std::size_t>(msg.width) * msg.height, msg.data.size(),
                              name);
}

}  // namespace flexcloud::ros_conv
