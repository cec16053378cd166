// Integration tests against a running flexcloud nodelet (started by the .test files with a real
// master and a nodelet manager). Each .test file runs one suite of this binary.
#include <dynamic_reconfigure/client.h>
#include <gtest/gtest.h>
#include <nav_msgs/Path.h>
#include <pcl_conversions/pcl_conversions.h>
#include <ros/ros.h>
#include <ros/topic.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <filesystem>
#include <fstream>
#include <future>

#include "flexcloud/Georeference.h"
#include "flexcloud/GeoreferenceConfig.h"
#include "flexcloud/Save.h"
#include "flexcloud/cloud_warp.h"
#include "flexcloud/io/memory.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/ros/conversions.h"
#include "flexcloud/sim/sim_cloud.h"
#include <std_srvs/Trigger.h>
#include <ros/master.h>
#include <ros/network.h>
#include <xmlrpcpp/XmlRpc.h>

#include <atomic>
#include <thread>

#include "flexcloud/ros/node_params.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;
using Cloud = sensor_msgs::PointCloud2;

flexcloud::Georeference::Response call(int control_points = 0) {
  flexcloud::Georeference srv;
  srv.request.control_points = control_points;
  EXPECT_TRUE(ros::service::waitForService("/flexcloud/georeference", ros::Duration(20.0)));
  EXPECT_TRUE(ros::service::call("/flexcloud/georeference", srv));
  return srv.response;
}

/// The latched map, or the first one stamped after `after`.
sensor_msgs::PointCloud2ConstPtr mapAfter(const ros::Time& after, double timeout) {
  ros::NodeHandle nh;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::ok() && ros::WallTime::now() < end) {
    auto m = ros::topic::waitForMessage<Cloud>("/flexcloud/global_map", nh, ros::Duration(1.0));
    if (m && m->header.stamp > after) return m;
  }
  return nullptr;
}

/// RMSE of the published map against the truth, point by point.
ErrorStats againstTruth(const Cloud& msg, const pcl::PCLPointCloud2& truth) {
  pcl::PCLPointCloud2 cloud;
  pcl_conversions::toPCL(msg, cloud);
  return compareClouds(cloud, truth, [](const Eigen::Vector3d& p) { return p; });
}

std::size_t sphereCount(const visualization_msgs::MarkerArray& a) {
  for (const auto& m : a.markers) {
    if (m.type == visualization_msgs::Marker::SPHERE_LIST) return m.points.size();
  }
  return 0;
}

/// A simulated drive published on the live topics.
class Live : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sim::SimParams sp;
    sp.seed = 5;
    sp.map_points = 200000;
    drive_ = new sim::SimDrive(sim::simulateDrive(sp));
  }
  static void TearDownTestSuite() { delete drive_; }

  void publishDrive() {
    // The publishers outlive this function: destroyed, they would drop what is still queued.
    ros::NodeHandle nh;
    fix_pub_ = nh.advertise<sensor_msgs::NavSatFix>("/fix", 10000);
    odom_pub_ = nh.advertise<nav_msgs::Odometry>("/odom", 10000);
    map_pub_ = nh.advertise<Cloud>("/map", 1, true);
    ros::Publisher& fix = fix_pub_;
    ros::Publisher& odom = odom_pub_;
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(20.0);
    while ((fix.getNumSubscribers() == 0 || odom.getNumSubscribers() == 0 ||
            map_pub_.getNumSubscribers() == 0) && ros::WallTime::now() < end) {
      ros::WallDuration(0.05).sleep();
    }
    ASSERT_GT(fix.getNumSubscribers(), 0u);
    Cloud map;
    ros_conv::toCloudMsg(sim::slamCloud(drive_->map), "map", map);
    map_pub_.publish(map);
    std::size_t k = 0;
    for (const auto& f : drive_->fixes) {
      fix.publish(ros_conv::toNavSatFix(f, "gnss"));
      if (++k % 500 == 0) ros::WallDuration(0.05).sleep();  // stay within the queues
    }
    for (const auto& p : drive_->slam) {
      odom.publish(ros_conv::toOdometry(p, "map", "base_link"));
      if (++k % 500 == 0) ros::WallDuration(0.05).sleep();
    }
  }

  /// Calls until the node has everything that was published (messages are still in flight).
  flexcloud::Georeference::Response callWhenComplete() {
    flexcloud::Georeference::Response r;
    for (int i = 0; i < 40; ++i) {
      r = call();
      if (r.success && r.poses == drive_->slam.size() && r.fixes_used == drive_->fixes.size() &&
          r.map_points == drive_->map.slam.size()) {
        break;
      }
      ros::WallDuration(0.25).sleep();
    }
    return r;
  }

  static sim::SimDrive* drive_;
  ros::Publisher fix_pub_, odom_pub_, map_pub_;
};
sim::SimDrive* Live::drive_ = nullptr;

TEST_F(Live, NoDataIsRefusedWithAMessage) {
  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::waitForService("/flexcloud/reset", ros::Duration(20.0)));
  ASSERT_TRUE(ros::service::call("/flexcloud/reset", reset));
  const auto r = call();
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("no GNSS fix received yet on /fix"), std::string::npos) << r.message;
}

TEST_F(Live, TopicsInAccurateMapOutTfAndMarkersToo) {
  publishDrive();
  const ros::Time before = ros::Time::now();
  const auto r = callWhenComplete();
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.poses, drive_->slam.size());
  EXPECT_EQ(r.poses_matched, drive_->slam.size());
  EXPECT_EQ(r.control_points, 200u);
  EXPECT_EQ(r.map_points, 200000u);
  EXPECT_EQ(r.points_outside, 0u);
  EXPECT_LT(r.rubbersheet.mae, 0.1);
  EXPECT_GT(r.aligned.mae, 1.0);
  EXPECT_NEAR(r.datum_lat, 48.262, 1e-9);  // the datum given in live.test

  const auto map = mapAfter(before, 20.0);
  ASSERT_TRUE(map);
  EXPECT_EQ(map->header.frame_id, "enu");
  EXPECT_EQ(map->width * map->height, 200000u);
  const ErrorStats e = againstTruth(*map, sim::truthCloud(drive_->map));
  std::printf("live: map vs truth RMSE %.3f m, MAX %.3f m\n", e.rmse, e.max);
  EXPECT_LE(e.rmse, 0.25);

  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  const auto tf = buffer.lookupTransform("enu", "map", ros::Time(0), ros::Duration(10.0));
  EXPECT_NEAR(tf.transform.translation.x, r.T_enu_map.translation.x, 1e-6);
  EXPECT_NEAR(tf.transform.translation.y, r.T_enu_map.translation.y, 1e-6);
  EXPECT_NEAR(tf.transform.translation.z, r.T_enu_map.translation.z, 1e-6);
  EXPECT_NEAR(std::abs(tf.transform.rotation.w), std::abs(r.T_enu_map.rotation.w), 1e-9);
  EXPECT_NEAR(tf.transform.rotation.z * (tf.transform.rotation.w < 0 ? -1 : 1),
              r.T_enu_map.rotation.z * (r.T_enu_map.rotation.w < 0 ? -1 : 1), 1e-9);

  ros::NodeHandle nh;
  const auto cps = ros::topic::waitForMessage<visualization_msgs::MarkerArray>(
      "/flexcloud/control_points", nh, ros::Duration(10.0));
  ASSERT_TRUE(cps);
  EXPECT_EQ(sphereCount(*cps), r.control_points);
  const auto tets = ros::topic::waitForMessage<visualization_msgs::MarkerArray>(
      "/flexcloud/tetrahedra", nh, ros::Duration(10.0));
  ASSERT_TRUE(tets);
  ASSERT_GE(tets->markers.size(), 2u);
  EXPECT_GT(tets->markers.back().points.size(), 2u * r.control_points);
  const auto dev = ros::topic::waitForMessage<visualization_msgs::MarkerArray>(
      "/flexcloud/deviation", nh, ros::Duration(10.0));
  ASSERT_TRUE(dev);
  EXPECT_EQ(dev->markers.back().points.size(), r.poses);
  const auto path = ros::topic::waitForMessage<nav_msgs::Path>("/flexcloud/path_rubbersheet", nh,
                                                               ros::Duration(10.0));
  ASSERT_TRUE(path);
  EXPECT_EQ(path->poses.size(), r.poses);
  const auto origin = ros::topic::waitForMessage<sensor_msgs::NavSatFix>("/flexcloud/origin", nh,
                                                                         ros::Duration(10.0));
  ASSERT_TRUE(origin);
  EXPECT_NEAR(origin->latitude, 48.262, 1e-9);
}

TEST_F(Live, ReconfigureRecomputesAndRepublishes) {
  publishDrive();
  const auto first = callWhenComplete();
  ASSERT_TRUE(first.success) << first.message;
  const auto before = mapAfter(ros::Time(0), 20.0);
  ASSERT_TRUE(before);
  const ros::Time stamp = before->header.stamp;

  dynamic_reconfigure::Client<flexcloud::GeoreferenceConfig> client("/flexcloud");
  flexcloud::GeoreferenceConfig config;
  ASSERT_TRUE(client.getCurrentConfiguration(config, ros::Duration(10.0)));
  EXPECT_EQ(config.control_points, static_cast<int>(first.control_points));
  config.control_points = 40;
  ASSERT_TRUE(client.setConfiguration(config));

  const auto after = mapAfter(stamp, 20.0);
  ASSERT_TRUE(after) << "no map republished after the reconfigure";
  ASSERT_EQ(after->data.size(), before->data.size());
  EXPECT_NE(after->data, before->data);  // fewer control points move the points differently
  ros::NodeHandle nh;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(10.0);
  std::size_t spheres = 0;
  while (spheres != 40 && ros::WallTime::now() < end) {
    const auto cps = ros::topic::waitForMessage<visualization_msgs::MarkerArray>(
        "/flexcloud/control_points", nh, ros::Duration(1.0));
    if (cps) spheres = sphereCount(*cps);
  }
  EXPECT_EQ(spheres, 40u);
  // An invalid change is refused and the values in use stay.
  config.interpolation = "cubic";
  client.setConfiguration(config);
  ASSERT_TRUE(client.getCurrentConfiguration(config, ros::Duration(10.0)));
  EXPECT_EQ(config.interpolation, "spline");
}

TEST_F(Live, ASecondCallDuringARunIsRefused) {
  publishDrive();
  ASSERT_TRUE(callWhenComplete().success);
  // A run on a 200k map takes tens of milliseconds at least; two calls started together overlap.
  auto a = std::async(std::launch::async, [] { return call(); });
  auto b = std::async(std::launch::async, [] { return call(); });
  const auto ra = a.get(), rb = b.get();
  EXPECT_NE(ra.success, rb.success) << ra.message << " / " << rb.message;
  const auto& refused = ra.success ? rb : ra;
  EXPECT_NE(refused.message.find("a georeferencing run is going"), std::string::npos)
      << refused.message;
  EXPECT_TRUE(call().success);  // and the node still works afterwards
}

/// The node reads ~bag itself through the same handlers (bag.test).
TEST(Bag, ReadsTheBagGeoreferencesAndSaves) {
  ros::NodeHandle pnh("~");
  std::string drive;
  ASSERT_TRUE(pnh.getParam("drive", drive));
  const auto map = mapAfter(ros::Time(0), 60.0);  // georeference_on_bag_end publishes it
  ASSERT_TRUE(map);
  EXPECT_EQ(map->header.frame_id, "enu");
  const pcl::PCLPointCloud2 truth = readPcd(drive + "/truth_map.pcd");
  EXPECT_EQ(map->width * map->height, truth.width * truth.height);
  const ErrorStats e = againstTruth(*map, truth);
  std::printf("bag: map vs truth RMSE %.3f m\n", e.rmse);
  EXPECT_LE(e.rmse, 0.25);

  const std::string out = (fs::temp_directory_path() / ("flexcloud_save_" + std::to_string(getpid()))).string();
  flexcloud::Save save;
  save.request.directory = out;
  ASSERT_TRUE(ros::service::call("/flexcloud/save", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  for (const char* f : {"map_georeferenced.pcd", "report.json", "origin.yaml", "control_points.txt",
                        "trajectory_rubbersheet.txt"}) {
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  }
  const pcl::PCLPointCloud2 saved = readPcd(out + "/map_georeferenced.pcd");
  EXPECT_EQ(saved.width * saved.height, truth.width * truth.height);
  fs::remove_all(out);

  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::call("/flexcloud/reset", reset));
  const auto r = call();
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("no GNSS fix"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace flexcloud


namespace flexcloud {
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

  std::atomic<bool> done{false};
  std::atomic<int> calls{0}, refused{0}, succeeded{0}, dropped{0};
  auto callLoop = [&] {
    // A persistent connection, as a client calling this often would hold: no master lookup and
    // no new connection per call. A call it cannot complete means the node failed.
    ros::NodeHandle h;
    ros::ServiceClient client = h.serviceClient<flexcloud::Georeference>("/flexcloud/georeference", true);
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
  std::thread tuner([&] {  // reconfigures and new maps all the while
    dynamic_reconfigure::Client<flexcloud::GeoreferenceConfig> client("/flexcloud");
    flexcloud::GeoreferenceConfig config;
    int k = 0;
    while (!done) {
      if (client.getCurrentConfiguration(config, ros::Duration(2.0))) {
        config.control_points = (++k % 2) ? 100 : 150;
        client.setConfiguration(config);
      }
      map.header.stamp = ros::Time::now();
      map_pub.publish(map);  // a new map, replacing the one a run may be warping
      ros::WallDuration(0.2).sleep();
    }
  });
  const ros::WallTime started = ros::WallTime::now();
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(40.0);
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
  std::printf("stress: %zu poses and fixes sent, %d calls (%d refused as busy, %d succeeded, %d "
              "not completed)\n", sent, calls.load(), refused.load(), succeeded.load(), dropped.load());
  EXPECT_EQ(sent, d.slam.size());  // the whole hour went through
  EXPECT_GT(calls.load(), 10);
  EXPECT_GT(refused.load(), 0);     // overlapping calls were refused, not queued
  EXPECT_GT(succeeded.load(), 0);
  EXPECT_EQ(dropped.load(), 0) << "calls the node did not complete";
  // The node still answers, every count adds up, memory stayed bounded.
  flexcloud::Georeference::Response r;
  for (int i = 0; i < 120 && !r.success; ++i) {  // a recompute may still be going: wait for it
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

/// Parameters from the parameter server: every wrong value is named, none falls back silently
/// (params.test also starts a nodelet with a bad value: it must not come up).
TEST(Params, WrongValuesAreNamedAndTheNodeDoesNotStart) {
  ros::NodeHandle nh("/bad_params");
  nh.setParam("control_points", std::string("many"));
  nh.setParam("stddev_threshold", -1.0);
  nh.setParam("interpolation", std::string("cubic"));
  nh.setParam("odom_type", std::string("imu"));
  nh.setParam("datum_lat", 48.0);
  nh.setParam("excluded_ranges", std::string("everything"));
  try {
    loadNodeParams(nh);
    FAIL() << "bad parameters were accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    for (const char* says : {"control_points: 'many' is not a number", "stddev_threshold -1",
                             "interpolation: 'cubic'", "odom_type 'imu'",
                             "give all three or none", "excluded_ranges: expected a list"}) {
      EXPECT_NE(what.find(says), std::string::npos) << says << " in: " << what;
    }
    EXPECT_EQ(what.find('\n'), std::string::npos);
  }
  ros::NodeHandle good("/good_params");
  good.setParam("control_points", 50);
  good.setParam("margin_z", 3);  // an int where a double belongs is fine
  const NodeParams p = loadNodeParams(good);
  EXPECT_EQ(p.core.control_points, 50);
  EXPECT_DOUBLE_EQ(p.core.margin_z, 3.0);
  // The nodelet of params.test has control_points 2: it logged why and offers no service.
  EXPECT_FALSE(ros::service::waitForService("/bad_nodelet/georeference", ros::Duration(3.0)));
}

}  // namespace
}  // namespace flexcloud

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "flexcloud_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
