#pragma once
// Every conversion between ROS messages and core types lives here.

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Transform.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <pcl/PCLPointCloud2.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/PointCloud2.h>

#include "flexcloud/Deviation.h"
#include "flexcloud/geo/geodesy.h"
#include "flexcloud/input/gnss.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/types.h"
#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud::ros_conv {

/// NO_FIX status -> has_fix false. Covariance type UNKNOWN, or an all-zero covariance -> NaN
/// std-devs (the pipeline then uses default_std_dev or drops the fix). Std-devs are the square
/// roots of the ENU diagonal.
RawFix fromNavSatFix(const sensor_msgs::NavSatFix& msg);
Pose fromPose(const ros::Time& stamp, const geometry_msgs::Pose& pose);
Pose fromOdometry(const nav_msgs::Odometry& msg);
Pose fromPoseStamped(const geometry_msgs::PoseStamped& msg);
Trajectory fromPath(const nav_msgs::Path& msg);

sensor_msgs::NavSatFix toNavSatFix(const RawFix& fix, const std::string& frame_id);
nav_msgs::Odometry toOdometry(const Pose& pose, const std::string& frame_id,
                              const std::string& child_frame_id);
nav_msgs::Path toPath(const Trajectory& poses, const std::string& frame_id);
geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& t);
geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& t);
flexcloud::Deviation toDeviationMsg(const ErrorStats& s);

/// Seconds as a ros::Time; throws flexcloud::Error when negative or out of range.
ros::Time toTime(double seconds);

void toCloudMsg(const pcl::PCLPointCloud2& cloud, const std::string& frame_id,
                sensor_msgs::PointCloud2& msg);
void fromCloudMsg(const sensor_msgs::PointCloud2& msg, pcl::PCLPointCloud2& cloud);
/// The cloud's fields as PCL describes them.
std::vector<pcl::PCLPointField> pclFields(const sensor_msgs::PointCloud2& msg);
/// Where x, y, z sit in the cloud's points; throws Error naming `name` (see XyzLayout::of).
XyzLayout xyzLayout(const sensor_msgs::PointCloud2& msg, const std::string& name);

}  // namespace flexcloud::ros_conv
