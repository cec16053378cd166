// The nodelet under load (stress.test).
#include <dynamic_reconfigure/client.h>
#include <ros/master.h>
#include <ros/network.h>
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
  // The node's configuration, read once: the tuner changes only the control-point count of this
  // copy. Re-read before every set, dynamic_reconfigure's client at times handed back a
  // configuration with a std-dev threshold of 0 (the node clamped it to the minimum, 0.001 m,
  // and logged that no pose had GNSS that good): a run that ended there could not succeed.
  dynamic_reconfigure::Client<flexcloud::GeoreferenceConfig> reconfigure("/flexcloud");
  flexcloud::GeoreferenceConfig config;
  ASSERT_TRUE(reconfigure.getCurrentConfiguration(config, ros::Duration(20.0)));
  ASSERT_DOUBLE_EQ(config.stddev_threshold, 0.1);  // config/georeference.yaml

  std::atomic<bool> done{false};
  std::atomic<int> calls{0}, refused{0}, succeeded{0}, dropped{0}, tunes{0};

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
      if (r.success) ++succeeded;
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
  // A bound against a hang, not a timing target: the whole hour must go through.
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(150.0);
  std::size_t sent = 0;
  for (std::size_t i = 0; i < d.slam.size() && ros::WallTime::now() < end; ++i) {
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
  EXPECT_GT(tunes.load(), 10);
  EXPECT_EQ(dropped.load(), 0) << "calls the node did not complete";
  // The node still answers, every count adds up, memory stayed bounded.
  flexcloud::Georeference::Response r;
  for (int i = 0; i < 240 && !r.success; ++i) {  // a recompute may still be going: wait for it
    r = call();
    if (!r.success) ros::WallDuration(0.25).sleep();
  }
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_LE(r.poses, 100000u);  // max_messages in stress.test
  EXPECT_EQ(r.map_points, 100000u);
  const double peak = nodePeakMb("/flexcloud_manager");
  std::printf("stress: nodelet manager peak memory %.0f MB\n", peak);
  EXPECT_GT(peak, 0.0);
  EXPECT_LT(peak, 1500.0);
}

}  // namespace
}  // namespace flexcloud::test
