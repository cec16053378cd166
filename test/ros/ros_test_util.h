#pragma once
// Helpers of the integration tests against a running flexcloud nodelet (the .test files start
// a real master and a nodelet manager; each runs one suite of flexcloud_ros_tests).

#include <gtest/gtest.h>
#include <pcl_conversions/pcl_conversions.h>
#include <ros/ros.h>
#include <ros/topic.h>
#include <visualization_msgs/MarkerArray.h>

#include <functional>
#include <initializer_list>

#include "flexcloud/Georeference.h"
#include "flexcloud/Result.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/ros/conversions.h"
#include "flexcloud/sim/drive_simulator.h"
#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud::test {

using Cloud = sensor_msgs::PointCloud2;

/// True once every publisher has a subscriber (the node is listening), false after `timeout` s.
inline bool subscribed(std::initializer_list<const ros::Publisher*> publishers, double timeout) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  const auto all = [&] {
    for (const auto* p : publishers) {
      if (p->getNumSubscribers() == 0) return false;
    }
    return true;
  };
  while (!all() && ros::WallTime::now() < end) ros::WallDuration(0.05).sleep();
  return all();
}

/// Publishes every pose (map -> base_link) and fix (frame gnss) of `d`, a short pause every
/// `batch` messages; returns how many poses went out.
inline std::size_t publishDrive(const sim::SimDrive& d, ros::Publisher& odom, ros::Publisher& fix,
                                std::size_t batch) {
  std::size_t sent = 0;
  for (std::size_t i = 0; i < d.slam.size(); ++i) {
    odom.publish(ros_conv::toOdometry(d.slam[i], "map", "base_link"));
    if (i < d.fixes.size()) fix.publish(ros_conv::toNavSatFix(d.fixes[i], "gnss"));
    if (++sent % batch == 0) ros::WallDuration(0.01).sleep();
  }
  return sent;
}

/// Calls the service `name` over a connection of its own that this side closes once the answer
/// is read. (roscpp's non-persistent call can see the server's close before the answer, ros_comm
/// issue 1976, and return false though the node answered: about one call in a few thousand on
/// a loaded machine, test_races' "to_ll answered: no answer".)
template <typename Srv>
bool callOver(const std::string& name, Srv& srv) {
  ros::ServiceClient client = ros::NodeHandle().serviceClient<Srv>(name, true);
  return client.call(srv);
}

/// Calls /NODE/georeference (waiting for the service first).
inline flexcloud::Georeference::Response call(int control_points = 0, double stddev_threshold = 0.0,
                                              const std::string& node = "/flexcloud") {
  flexcloud::Georeference srv;
  srv.request.control_points = control_points;
  srv.request.stddev_threshold = stddev_threshold;
  EXPECT_TRUE(ros::service::waitForService(node + "/georeference", ros::Duration(20.0)));
  EXPECT_TRUE(callOver(node + "/georeference", srv));
  return srv.response;
}

/// Calls a service of the node (waiting for it first); the call's success is asserted.
template <typename Srv>
Srv callService(const std::string& name, Srv srv = {}) {
  EXPECT_TRUE(ros::service::waitForService(name, ros::Duration(20.0))) << name;
  EXPECT_TRUE(callOver(name, srv)) << name;
  return srv;
}

/// The first message on `topic` (latched or new) that `pred` accepts, within `timeout` s.
template <typename M>
boost::shared_ptr<const M> messageWhere(const std::string& topic,
                                        const std::function<bool(const M&)>& pred, double timeout) {
  ros::NodeHandle nh;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::ok() && ros::WallTime::now() < end) {
    auto m = ros::topic::waitForMessage<M>(topic, nh, ros::Duration(1.0));
    if (m && pred(*m)) return m;
  }
  return nullptr;
}

/// The latched map, or the first one stamped after `after`.
inline sensor_msgs::PointCloud2ConstPtr mapAfter(const ros::Time& after, double timeout) {
  return messageWhere<Cloud>(
      "/flexcloud/global_map", [&](const Cloud& m) { return m.header.stamp > after; }, timeout);
}

/// The ~result message stamped after `after` that `pred` accepts.
inline flexcloud::ResultConstPtr resultWhere(const ros::Time& after,
                                             const std::function<bool(const Result&)>& pred,
                                             double timeout = 20.0) {
  return messageWhere<Result>(
      "/flexcloud/result", [&](const Result& m) { return m.header.stamp >= after && pred(m); },
      timeout);
}

/// The value of a parameter in a ~result message, "" when it is not listed.
inline std::string parameterOf(const Result& r, const std::string& name) {
  for (const auto& p : r.parameters) {
    if (p.name == name) return p.value;
  }
  return "";
}

/// RMSE of the published map against the truth, point by point.
inline ErrorStats againstTruth(const Cloud& msg, const pcl::PCLPointCloud2& truth) {
  pcl::PCLPointCloud2 cloud;
  pcl_conversions::toPCL(msg, cloud);
  return compareClouds(cloud, truth, [](const Eigen::Vector3d& p) { return p; });
}

inline std::size_t sphereCount(const visualization_msgs::MarkerArray& a) {
  for (const auto& m : a.markers) {
    if (m.type == visualization_msgs::Marker::SPHERE_LIST) return m.points.size();
  }
  return 0;
}

}  // namespace flexcloud::test
