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

/// What the callers and the tuner saw during the flood.
struct Counts {
  std::atomic<int> calls{0}, refused{0}, succeeded{0}, dropped{0}, tunes{0};
  std::atomic<std::uint32_t> most_poses{0};  ///< of any result made during the flood

  /// Calls overlapped a run, one succeeded, and reconfigures went through.
  bool enough() const { return calls > 10 && refused > 0 && succeeded > 0 && tunes > 2; }
};

/// Calls ~georeference until `done`, over a persistent connection (as a client calling this
/// often would hold). A call it cannot complete means the node failed.
void callUntil(const std::atomic<bool>& done, Counts& c) {
  ros::NodeHandle h;
  ros::ServiceClient client =
      h.serviceClient<flexcloud::Georeference>("/flexcloud/georeference", true);
  while (!done) {
    flexcloud::Georeference srv;
    if (!client.call(srv)) {
      ++c.dropped;
      client = h.serviceClient<flexcloud::Georeference>("/flexcloud/georeference", true);
      continue;
    }
    const auto& r = srv.response;
    ++c.calls;
    const bool busy = r.message.find("a georeferencing run is going") != std::string::npos;
    if (r.success) {
      ++c.succeeded;
      std::uint32_t seen = c.most_poses;
      while (r.poses > seen && !c.most_poses.compare_exchange_weak(seen, r.poses)) {
      }
    }
    if (busy) ++c.refused;
    if (!r.success && !busy) std::printf("stress: call answered: %s\n", r.message.c_str());
  }
}

/// Sends reconfigures (the control-point count of its own copy of `config`, so every
/// configuration is valid) and new maps until `done`.
void tuneUntil(const std::atomic<bool>& done, flexcloud::GeoreferenceConfig config, Cloud map,
               ros::Publisher& map_pub, Counts& c) {
  dynamic_reconfigure::Client<flexcloud::GeoreferenceConfig> reconfigure("/flexcloud");
  while (!done) {
    config.control_points = (++c.tunes % 2) ? 100 : 150;
    reconfigure.setConfiguration(config);
    map.header.stamp = ros::Time::now();
    map_pub.publish(map);            // a new map, replacing the one a run may be warping
    ros::WallDuration(0.2).sleep();  // the pace of a user at a slider, not a wait for anything
  }
}

/// Ends the flood: its publishers go, and ~reset is called until one, half a second after the
/// last, finds nothing to clear: what the flood left in the node's queues (up to queue_size
/// messages a topic) has arrived and is forgotten.
void drainFlood(ros::Publisher& odom, ros::Publisher& fix) {
  odom.shutdown();
  fix.shutdown();
  std::string said;
  for (int i = 0; i < 60; ++i) {
    const auto r = callService<std_srvs::Trigger>("/flexcloud/reset");
    ASSERT_TRUE(r.response.success) << r.response.message;
    said = r.response.message;
    if (i > 0 && said.rfind("cleared 0 fixes, 0 poses and the result", 0) == 0) return;
    ros::WallDuration(0.5).sleep();  // the interval between looks, not a wait for anything
  }
  FAIL() << "the flood still arrives 30 s after it ended: " << said;
}

/// After the flood the node still works: a drive sent at its pace on new publishers gives a
/// full result with the map of the flood's last replacement.
void aCalmDriveGivesAFullResult() {
  ros::NodeHandle nh;
  ros::Publisher fix = nh.advertise<sensor_msgs::NavSatFix>("/fix", 20000);
  ros::Publisher odom = nh.advertise<nav_msgs::Odometry>("/odom", 20000);
  ASSERT_TRUE(subscribed({&fix, &odom}, 20.0));
  sim::SimParams cp;
  cp.map_points = 0;
  const sim::SimDrive calm = sim::simulateDrive(cp);
  publishDrive(calm, odom, fix, 100);
  flexcloud::Georeference::Response r;
  for (int i = 0; i < 40 && r.poses != calm.slam.size(); ++i) {  // until all have arrived
    ros::WallDuration(0.5).sleep();
    r = call();
  }
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.poses, calm.slam.size());
  EXPECT_EQ(r.map_points, 100000u);
  EXPECT_LT(r.rubbersheet.mae, 0.1);
}

/// An hour of 100 Hz fixes and odometry pushed as fast as the link takes them, while service
/// calls, reconfigures and new maps arrive (stress.test).
TEST(Stress, AnHourAt100HzWithCallsReconfiguresAndNewMaps) {
  sim::SimParams sp;
  sp.length = 12.0 * 3600.0;
  sp.odom_rate = 100.0;
  sp.gnss_rate = 100.0;
  sp.map_points = 0;
  const sim::SimDrive d = sim::simulateDrive(sp);
  sim::SimParams mp;
  mp.map_points = 100000;
  Cloud map;
  ros_conv::toCloudMsg(sim::slamCloud(sim::simulateDrive(mp).map), "map", map);

  ros::NodeHandle nh;
  ros::Publisher fix = nh.advertise<sensor_msgs::NavSatFix>("/fix", 20000);
  ros::Publisher odom = nh.advertise<nav_msgs::Odometry>("/odom", 20000);
  ros::Publisher map_pub = nh.advertise<Cloud>("/map", 1, true);
  ASSERT_TRUE(subscribed({&fix, &odom}, 20.0));
  ASSERT_TRUE(ros::service::waitForService("/flexcloud/georeference", ros::Duration(20.0)));
  dynamic_reconfigure::Client<flexcloud::GeoreferenceConfig> reconfigure("/flexcloud");
  flexcloud::GeoreferenceConfig config;
  ASSERT_TRUE(reconfigure.getCurrentConfiguration(config, ros::Duration(20.0)));
  ASSERT_DOUBLE_EQ(config.stddev_threshold, 0.1);  // config/georeference.yaml

  std::atomic<bool> done{false};
  Counts c;
  std::thread caller_a([&] { callUntil(done, c); });  // two callers: calls overlap runs
  std::thread caller_b([&] { callUntil(done, c); });
  std::thread tuner([&] { tuneUntil(done, config, map, map_pub, c); });
  const std::size_t sent = publishDrive(d, odom, fix, 2000);  // the whole hour
  // The load stays on until calls overlapped a run, one succeeded and reconfigures went
  // through (stress.test's time-limit guards against a hang).
  while (!c.enough()) ros::WallDuration(0.1).sleep();
  done = true;
  caller_a.join();
  caller_b.join();
  tuner.join();
  std::printf(
      "stress: %zu poses and fixes sent, %d calls (%d refused as busy, %d succeeded, %d "
      "not completed), %d reconfigures\n",
      sent, c.calls.load(), c.refused.load(), c.succeeded.load(), c.dropped.load(), c.tunes.load());
  EXPECT_EQ(sent, d.slam.size());           // the whole hour went through
  EXPECT_LE(c.most_poses.load(), 100000u);  // max_messages in stress.test bounds what is kept
  EXPECT_EQ(c.dropped.load(), 0) << "calls the node did not complete";
  // What the node kept of a flood its queues thinned out is up to the scheduler, so no result
  // of it is asserted beyond the bound; the node must still work.
  drainFlood(odom, fix);
  aCalmDriveGivesAFullResult();
  const double peak = nodePeakMb("/flexcloud_manager");
  std::printf("stress: nodelet manager peak memory %.0f MB\n", peak);
  EXPECT_GT(peak, 0.0);
  EXPECT_LT(peak, 1500.0);
}

}  // namespace
}  // namespace flexcloud::test
