// The nodelet under load (stress.test).
#include <dynamic_reconfigure/client.h>
#include <ros/master.h>
#include <ros/network.h>
#include <std_srvs/Trigger.h>
#include <xmlrpcpp/XmlRpc.h>

#include <atomic>
#include <thread>

#include "flexcloud/GeoreferenceConfig.h"
#include "flexcloud/io/memory.h"
#include "flexcloud/ros/conversions.h"
#include "flexcloud/sim/sim_cloud.h"
#include "ros_test_util.h"

namespace flexcloud::test {
namespace {

/// Peak resident memory (MB) of a ROS node, through its pid from the node's XML-RPC API.
double nodePeakMb(const std::string& node) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = node;
  if (!ros::master::execute("lookupNode", args, result, payload, true)) return -1.0;
  const std::string uri = payload;
  std::string host;
  std::uint32_t port = 0;
  if (!ros::network::splitURI(uri, host, port)) return -1.0;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue a, r;
  a[0] = ros::this_node::getName();
  if (!client.execute("getPid", a, r) || r.size() < 3) return -1.0;
  const int pid = r[2];
  return peakMemoryMb("/proc/" + std::to_string(pid) + "/status");
}

/// An hour of 100 Hz fixes and odometry pushed as fast as the link takes them (for a bounded
/// time), while service calls, reconfigures and new maps arrive (stress.test).
TEST(Stress, AnHourAt100HzWithCallsReconfiguresAndNewMaps) {
  sim::SimParams sp;
  sp.length = 12.0 * 3600.0;
  sp.odom_rate = 100.0;
  sp.gnss_rate = 100.0;
  sp.map_points = 0;
  const sim::SimDrive d = sim::simulateDrive(sp);
  sim::SimParams mp;
  mp.map_points = 100000;
  const sim::SimDrive small = sim::simulateDrive(mp);
  Cloud map;
  ros_conv::toCloudMsg(sim::slamCloud(small.map), "map", map);

  ros::NodeHandle nh;
  ros::Publisher fix = nh.advertise<sensor_msgs::NavSatFix>("/fix", 20000);
  ros::Publisher odom = nh.advertise<nav_msgs::Odometry>("/odom", 20000);
  ros::Publisher map_pub = nh.advertise<Cloud>("/map", 1, true);
  const ros::WallTime wait_end = ros::WallTime::now() + ros::WallDuration(20.0);
  while ((fix.getNumSubscribers() == 0 || odom.getNumSubscribers() == 0) &&
         ros::WallTime::now() < wait_end) {
    ros::WallDuration(0.05).sleep();
  }
  ASSERT_GT(odom.getNumSubscribers(), 0u);
  ASSERT_TRUE(ros::service::waitForService("/flexcloud/georeference", ros::Duration(20.0)));
  // The node's configuration, read once: the tuner changes only the control-point count of its
  // own copy, so every configuration it sends is a valid one whatever the client has cached.
  dynamic_reconfigure::Client<flexcloud::GeoreferenceConfig> reconfigure("/flexcloud");
  flexcloud::GeoreferenceConfig config;
  ASSERT_TRUE(reconfigure.getCurrentConfiguration(config, ros::Duration(20.0)));
  ASSERT_DOUBLE_EQ(config.stddev_threshold, 0.1);  // config/georeference.yaml

  std::atomic<bool> done{false};
  std::atomic<int> calls{0}, refused{0}, succeeded{0}, dropped{0}, tunes{0};
  std::atomic<std::uint32_t> most_poses{0};  // of any result made during the flood

  auto callLoop = [&] {
    // A persistent connection, as a client calling this often would hold: no master lookup and
    // no new connection per call. A call it cannot complete means the node failed.
    ros::NodeHandle h;
    ros::ServiceClient client =
        h.serviceClient<flexcloud::Georeference>("/flexcloud/georeference", true);
    while (!done) {
      flexcloud::Georeference srv;
      if (!client.call(srv)) {
        ++dropped;
        client = h.serviceClient<flexcloud::Georeference>("/flexcloud/georeference", true);
        continue;
      }
      const auto& r = srv.response;
      ++calls;
      if (r.success) {
        ++succeeded;
        std::uint32_t seen = most_poses;
        while (r.poses > seen && !most_poses.compare_exchange_weak(seen, r.poses)) {
        }
      }
      if (r.message.find("a georeferencing run is going") != std::string::npos) ++refused;
      if (!r.success && r.message.find("a georeferencing run is going") == std::string::npos) {
        std::printf("stress: call answered: %s\n", r.message.c_str());
      }
    }
  };
  std::thread caller_a(callLoop), caller_b(callLoop);  // two callers: calls overlap runs
  std::thread tuner([&] {                              // reconfigures and new maps all the while
    flexcloud::GeoreferenceConfig next = config;
    while (!done) {
      next.control_points = (++tunes % 2) ? 100 : 150;
      reconfigure.setConfiguration(next);
      map.header.stamp = ros::Time::now();
      map_pub.publish(map);  // a new map, replacing the one a run may be warping
      ros::WallDuration(0.2).sleep();
    }
  });
  const ros::WallTime started = ros::WallTime::now();
  std::size_t sent = 0;  // the whole hour (stress.test's time-limit guards against a hang)
  for (std::size_t i = 0; i < d.slam.size(); ++i) {
    odom.publish(ros_conv::toOdometry(d.slam[i], "map", "base_link"));
    if (i < d.fixes.size()) fix.publish(ros_conv::toNavSatFix(d.fixes[i], "gnss"));
    if (++sent % 2000 == 0) ros::WallDuration(0.01).sleep();
  }
  while (ros::WallTime::now() < started + ros::WallDuration(10.0)) ros::WallDuration(0.1).sleep();
  done = true;
  caller_a.join();
  caller_b.join();
  tuner.join();
  std::printf(
      "stress: %zu poses and fixes sent, %d calls (%d refused as busy, %d succeeded, %d "
      "not completed), %d reconfigures\n",
      sent, calls.load(), refused.load(), succeeded.load(), dropped.load(), tunes.load());
  EXPECT_EQ(sent, d.slam.size());  // the whole hour went through
  EXPECT_GT(calls.load(), 10);
  EXPECT_GT(refused.load(), 0);  // overlapping calls were refused, not queued
  EXPECT_GT(succeeded.load(), 0);
  EXPECT_LE(most_poses.load(), 100000u);  // max_messages in stress.test bounds what is kept
  EXPECT_GT(tunes.load(), 0);  // the flood lasts 10 s at least: reconfigures ran through it
  EXPECT_EQ(dropped.load(), 0) << "calls the node did not complete";
  // What the node kept of a flood that its queues thinned out is up to the scheduler (a run
  // saw only fixes older than every pose it kept), so no result of it is asserted; the node
  // must still work: forgotten by ~reset, a drive sent at its pace gives a full result.
  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::call("/flexcloud/reset", reset));
  ASSERT_TRUE(reset.response.success) << reset.response.message;
  sim::SimParams cp;
  cp.map_points = 0;
  const sim::SimDrive calm = sim::simulateDrive(cp);
  for (std::size_t i = 0; i < calm.slam.size(); ++i) {
    odom.publish(ros_conv::toOdometry(calm.slam[i], "map", "base_link"));
    if (i < calm.fixes.size()) fix.publish(ros_conv::toNavSatFix(calm.fixes[i], "gnss"));
    if (i % 100 == 0) ros::WallDuration(0.01).sleep();
  }
  flexcloud::Georeference::Response r;
  for (int i = 0; i < 40 && r.poses != calm.slam.size(); ++i) {  // until all have arrived
    ros::WallDuration(0.5).sleep();
    r = call();
  }
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.poses, calm.slam.size());
  EXPECT_EQ(r.map_points, 100000u);  // the map of the flood's last replacement
  EXPECT_LT(r.rubbersheet.mae, 0.1);
  const double peak = nodePeakMb("/flexcloud_manager");
  std::printf("stress: nodelet manager peak memory %.0f MB\n", peak);
  EXPECT_GT(peak, 0.0);
  EXPECT_LT(peak, 1500.0);
}

}  // namespace
}  // namespace flexcloud::test
