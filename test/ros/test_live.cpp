// The nodelet on live topics (live.test): a simulated drive published on fix, odom and map.
#include <dynamic_reconfigure/client.h>
#include <nav_msgs/Path.h>
#include <rosgraph_msgs/Log.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <future>
#include <mutex>
#include <optional>

#include "flexcloud/GeoreferenceConfig.h"
#include "flexcloud/LoadMap.h"
#include "flexcloud/Save.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/ros/conversions.h"
#include "flexcloud/sim/sim_cloud.h"
#include "ros_test_util.h"

namespace flexcloud::test {
namespace {

namespace fs = std::filesystem;

const Eigen::Vector3d kLeverArm(0.8, 0.0, 1.5);

/// A simulated drive published on the live topics.
class Live : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sim::SimParams sp;
    sp.seed = 5;
    sp.map_points = 200000;
    sp.lever_arm = kLeverArm;  // the antenna sits above the body's origin, as TF says
    drive_ = new sim::SimDrive(sim::simulateDrive(sp));
  }
  static void TearDownTestSuite() { delete drive_; }

  /// Publishes the map and the first `share` of the fixes (in `fix_frame`, with latitude and
  /// longitude swapped where `swapped`) and poses.
  void publishDrive(double share = 1.0, const std::string& fix_frame = "gnss",
                    bool swapped = false) {
    // The lever arm comes from TF: body frame of the odometry -> frame of the fixes.
    geometry_msgs::TransformStamped antenna;
    antenna.header.stamp = ros::Time::now();
    antenna.header.frame_id = "base_link";
    antenna.child_frame_id = "gnss";
    antenna.transform.translation.x = kLeverArm.x();
    antenna.transform.translation.y = kLeverArm.y();
    antenna.transform.translation.z = kLeverArm.z();
    antenna.transform.rotation.w = 1.0;
    static tf2_ros::StaticTransformBroadcaster broadcaster;
    broadcaster.sendTransform(antenna);
    // The publishers outlive this function: destroyed, they would drop what is still queued.
    ros::NodeHandle nh;
    fix_pub_ = nh.advertise<sensor_msgs::NavSatFix>("/fix", 10000);
    odom_pub_ = nh.advertise<nav_msgs::Odometry>("/odom", 10000);
    map_pub_ = nh.advertise<Cloud>("/map", 1, true);
    ros::Publisher& fix = fix_pub_;
    ros::Publisher& odom = odom_pub_;
    ASSERT_TRUE(subscribed({&fix, &odom, &map_pub_}, 20.0));
    Cloud map;
    ros_conv::toCloudMsg(sim::slamCloud(drive_->map), "map", map);
    map_pub_.publish(map);
    std::size_t k = 0;
    const auto part = [share](std::size_t n) { return static_cast<std::size_t>(share * n); };
    for (std::size_t i = 0; i < part(drive_->fixes.size()); ++i) {
      sensor_msgs::NavSatFix m = ros_conv::toNavSatFix(drive_->fixes[i], fix_frame);
      if (swapped) std::swap(m.latitude, m.longitude);
      fix.publish(m);
      if (++k % 500 == 0) ros::WallDuration(0.05).sleep();  // stay within the queues
    }
    for (std::size_t i = 0; i < part(drive_->slam.size()); ++i) {
      odom.publish(ros_conv::toOdometry(drive_->slam[i], "map", "base_link"));
      if (++k % 500 == 0) ros::WallDuration(0.05).sleep();
    }
  }

  /// Calls ~georeference until `done` holds for the answer (messages are still in flight), at
  /// most 40 times; returns the last answer.
  static flexcloud::Georeference::Response callUntil(
      const std::function<bool(const flexcloud::Georeference::Response&)>& done) {
    flexcloud::Georeference::Response r;
    for (int i = 0; i < 40; ++i) {
      r = call();
      if (done(r)) break;
      ros::WallDuration(0.25).sleep();
    }
    return r;
  }

  /// Calls until the node has everything that was published.
  flexcloud::Georeference::Response callWhenComplete() {
    return callUntil([](const flexcloud::Georeference::Response& r) {
      return r.success && r.poses == drive_->slam.size() && r.fixes_used == drive_->fixes.size() &&
             r.map_points == drive_->map.slam.size();
    });
  }

  /// ~reset; returns what it said.
  static std::string reset() {
    const auto r = callService<std_srvs::Trigger>("/flexcloud/reset");
    EXPECT_TRUE(r.response.success) << r.response.message;
    return r.response.message;
  }

  static sim::SimDrive* drive_;
  ros::Publisher fix_pub_, odom_pub_, map_pub_;
};
sim::SimDrive* Live::drive_ = nullptr;

TEST_F(Live, NoDataIsRefusedWithAMessage) {
  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::waitForService("/flexcloud/reset", ros::Duration(20.0)));
  ASSERT_TRUE(callOver("/flexcloud/reset", reset));
  // A NavSatFix topic under another name is named as the one to remap to.
  ros::NodeHandle nh;
  const ros::Publisher other = nh.advertise<sensor_msgs::NavSatFix>("/gnss/navsat", 1);
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(10.0);
  std::string message;
  while (message.find("/gnss/navsat") == std::string::npos && ros::WallTime::now() < end) {
    const auto r = call();
    EXPECT_FALSE(r.success);
    message = r.message;
    ros::WallDuration(0.1).sleep();
  }
  EXPECT_NE(message.find("no GNSS fix received yet on /fix"), std::string::npos) << message;
  EXPECT_NE(message.find("sensor_msgs/NavSatFix is published on /gnss/navsat: remap to it"),
            std::string::npos)
      << message;
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
  EXPECT_NEAR(r.datum_lat, 48.262, 1e-9);           // the datum given in live.test
  EXPECT_NEAR(r.lever_arm.x, kLeverArm.x(), 1e-9);  // from TF
  EXPECT_NEAR(r.lever_arm.z, kLeverArm.z(), 1e-9);
  EXPECT_EQ(r.lever_arm_source, "tf base_link -> gnss");
  EXPECT_FALSE(r.antenna_offset_estimated);  // a lever arm given is taken as it is
  // How far from the truth, read first: the simulated RTK drive's sigmas are centimetres.
  EXPECT_EQ(r.method, "fusion");
  EXPECT_GT(r.sigma_h_median, 0.001);
  EXPECT_LT(r.sigma_h_median, 0.1);
  EXPECT_LE(r.sigma_h_median, r.sigma_h_p95);
  EXPECT_LE(r.sigma_h_p95, r.worst_sigma_h);
  EXPECT_LT(r.worst_from, r.worst_to);
  // Beside it, the map's by band of distance from the route (0-10, 10-30, 30-50 m), growing.
  ASSERT_EQ(r.map_sigma_h_median.size(), 3U);
  ASSERT_EQ(r.map_sigma_h_p95.size(), 3U);
  EXPECT_GT(r.map_sigma_h_median[0], 0.001);
  EXPECT_LT(r.map_sigma_h_median[0], 0.1);
  for (std::size_t b = 1; b < 3; ++b)
    EXPECT_GT(r.map_sigma_h_median[b], r.map_sigma_h_median[b - 1]);
  for (std::size_t b = 0; b < 3; ++b) EXPECT_GE(r.map_sigma_h_p95[b], r.map_sigma_h_median[b]);
  EXPECT_GE(r.rejected_share, 0.0);
  EXPECT_LT(r.rejected_share, 0.5);

  const auto map = mapAfter(before, 20.0);
  ASSERT_TRUE(map);
  EXPECT_EQ(map->header.frame_id, "enu");
  EXPECT_EQ(map->width * map->height, 200000u);
  const ErrorStats e = againstTruth(*map, sim::truthCloud(drive_->map));
  std::printf("live: map vs truth RMSE %.3f m, MAX %.3f m\n", e.rmse, e.max);
  EXPECT_LE(e.rmse, 0.25);
  // point_sigma (live.test): sigma_h and sigma_v after the map's own fields, centimetres here.
  ASSERT_GE(map->fields.size(), 5u);
  const sensor_msgs::PointField& sigma_h = map->fields[map->fields.size() - 2];
  EXPECT_EQ(sigma_h.name, "sigma_h");
  EXPECT_EQ(map->fields.back().name, "sigma_v");
  EXPECT_EQ(sigma_h.offset + 8, map->point_step);
  float h = 0.0F;
  std::memcpy(&h, map->data.data() + 1000 * map->point_step + sigma_h.offset, 4);
  EXPECT_GT(h, 0.01F);
  EXPECT_LT(h, 0.5F);

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
  const auto sigma = ros::topic::waitForMessage<visualization_msgs::MarkerArray>(
      "/flexcloud/sigma", nh, ros::Duration(10.0));
  ASSERT_TRUE(sigma);
  EXPECT_EQ(sigma->markers.back().type, visualization_msgs::Marker::LINE_STRIP);
  EXPECT_EQ(sigma->markers.back().points.size(), r.poses);
  EXPECT_EQ(sigma->markers.back().colors.size(), r.poses);
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
  // The 40 asked for, and those the sheet adds where the fused trajectory breaks (at most as
  // many again on this drive).
  std::size_t spheres = 0;
  while ((spheres < 40 || spheres > 80) && ros::WallTime::now() < end) {
    const auto cps = ros::topic::waitForMessage<visualization_msgs::MarkerArray>(
        "/flexcloud/control_points", nh, ros::Duration(1.0));
    if (cps) spheres = sphereCount(*cps);
  }
  EXPECT_GE(spheres, 40u);
  EXPECT_LE(spheres, 80u);
  // A value beyond the range is clamped by dynamic_reconfigure: the node says so in the log and
  // in the next result's warnings.
  const ros::Time clamped_at = ros::Time::now();
  config.control_points = -3;
  ASSERT_TRUE(client.setConfiguration(config));
  const auto clamped = resultWhere(
      clamped_at, [](const Result& m) { return m.success; }, 30.0);
  ASSERT_TRUE(clamped);
  EXPECT_EQ(parameterOf(*clamped, "control_points"), "4");
  bool said = false;
  for (const auto& w : clamped->warnings) {
    said = said || w.find(
                       "control_points is 4, the least it can be in [4, 100000] "
                       "(dynamic_reconfigure sets a value asked beyond it to the bound)") !=
                       std::string::npos;
  }
  EXPECT_TRUE(said) << "no warning of the clamped control_points";
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

/// ~result (12): the counts, metrics and the parameters of the published result.
TEST_F(Live, ResultTopicDescribesThePublishedResult) {
  publishDrive();
  const ros::Time before = ros::Time::now();
  const auto r = callWhenComplete();
  ASSERT_TRUE(r.success) << r.message;
  const auto msg = resultWhere(before, [](const Result& m) { return m.has_result; });
  ASSERT_TRUE(msg);
  EXPECT_TRUE(msg->success);
  EXPECT_EQ(msg->message, r.message);
  EXPECT_EQ(msg->poses, r.poses);
  EXPECT_EQ(msg->fixes_used, r.fixes_used);
  EXPECT_EQ(msg->fixes_rejected, r.fixes_rejected);
  EXPECT_NEAR(msg->time_offset, 0.0, 0.02);       // the drive's clocks agree
  EXPECT_TRUE(std::isnan(msg->estimated_std_h));  // every fix has its covariance
  EXPECT_LT(msg->slam_noise_scale,
            1.05);                      // not raised: the simulated SLAM drifts as its noise says
  EXPECT_LT(msg->slam_jitter_v, 0.01);  // and does not jitter from pose to pose
  EXPECT_EQ(msg->slam_jitter_v, r.slam_jitter_v);
  EXPECT_LT(msg->poses_moved_to_fixes, msg->poses / 10);
  ros::NodeHandle nh;
  const auto rejected = ros::topic::waitForMessage<visualization_msgs::MarkerArray>(
      "/flexcloud/rejected_fixes", nh, ros::Duration(10.0));
  ASSERT_TRUE(rejected);
  EXPECT_EQ(sphereCount(*rejected), r.fixes_rejected);
  for (const auto& m : rejected->markers) {  // rviz shows an empty list as an error
    EXPECT_FALSE(m.type == visualization_msgs::Marker::SPHERE_LIST && m.points.empty());
  }
  EXPECT_EQ(msg->control_points, r.control_points);
  EXPECT_EQ(msg->map_points, r.map_points);
  EXPECT_DOUBLE_EQ(msg->rubbersheet.mae, r.rubbersheet.mae);
  EXPECT_EQ(parameterOf(*msg, "control_points"), std::to_string(r.control_points));
  EXPECT_EQ(parameterOf(*msg, "interpolation"), "spline");
  EXPECT_EQ(parameterOf(*msg, "datum_lat"), "48.262");
  EXPECT_EQ(parameterOf(*msg, "queue_size"), "5000");
}

/// A retune whose recompute fails (12): the published result stays, and ~result and the log say
/// so, with the parameters the published map was made with.
TEST_F(Live, AFailedRecomputeKeepsThePublishedResultAndSaysSo) {
  publishDrive();
  const auto good = callWhenComplete();
  ASSERT_TRUE(good.success) << good.message;
  const auto map = mapAfter(ros::Time(0), 20.0);
  ASSERT_TRUE(map);
  const ros::Time before = ros::Time::now();
  dynamic_reconfigure::Client<flexcloud::GeoreferenceConfig> client("/flexcloud");
  flexcloud::GeoreferenceConfig config;
  ASSERT_TRUE(client.getCurrentConfiguration(config, ros::Duration(10.0)));
  const double threshold = config.stddev_threshold;
  // In range, but no fix is that good: without the fusion (which would weigh them all) the
  // alignment finds none.
  config.stddev_threshold = 0.001;
  config.fusion = false;
  ASSERT_TRUE(client.setConfiguration(config));
  const auto failed = resultWhere(before, [](const Result& m) { return !m.success; });
  ASSERT_TRUE(failed) << "no failure reported on ~result";
  EXPECT_NE(failed->message.find("within stddev_threshold 0.001 m"), std::string::npos)
      << failed->message;
  EXPECT_TRUE(failed->has_result);
  EXPECT_EQ(parameterOf(*failed, "stddev_threshold"), "0.1");
  EXPECT_EQ(failed->map_points, good.map_points);
  const auto still = ros::topic::waitForMessage<Cloud>("/flexcloud/global_map", ros::Duration(5.0));
  ASSERT_TRUE(still);
  EXPECT_EQ(still->header.stamp, map->header.stamp);  // not replaced
  config.stddev_threshold = threshold;
  config.fusion = true;
  ASSERT_TRUE(client.setConfiguration(config));
  EXPECT_TRUE(resultWhere(before, [](const Result& m) { return m.success && m.has_result; }));
}

/// A request beyond the ranges dynamic_reconfigure allows is refused, naming the field (12).
TEST_F(Live, ARequestOutOfRangeIsRefusedNamingTheField) {
  const auto few = call(2);
  EXPECT_FALSE(few.success);
  EXPECT_NE(few.message.find("control_points 2 is not in [4, 100000]"), std::string::npos)
      << few.message;
  const auto bad = call(0, -1.0);
  EXPECT_FALSE(bad.success);
  EXPECT_NE(bad.message.find("stddev_threshold -1 m is not in [0.001, 100]"), std::string::npos)
      << bad.message;
}

/// A request's value becomes the node's and says so: the response's message names what it
/// changed (it did so silently before), and dynamic_reconfigure shows the new value.
TEST_F(Live, ARequestThatChangesAValueSaysSo) {
  publishDrive();
  ASSERT_TRUE(callWhenComplete().success);
  dynamic_reconfigure::Client<flexcloud::GeoreferenceConfig> client("/flexcloud");
  flexcloud::GeoreferenceConfig config;
  ASSERT_TRUE(client.getCurrentConfiguration(config, ros::Duration(10.0)));
  const int was = config.control_points;
  const int asked = was == 60 ? 70 : 60;
  const auto r = call(asked);
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.message.rfind("the request set control_points " + std::to_string(was) + " -> " +
                                std::to_string(asked),
                            0),
            0u)
      << r.message;
  const auto same = call(asked);  // the node's value already: nothing to say
  EXPECT_EQ(same.message.find("the request set"), std::string::npos) << same.message;
  ASSERT_TRUE(client.getCurrentConfiguration(config, ros::Duration(10.0)));
  EXPECT_EQ(config.control_points, asked);
  config.control_points = was;
  ASSERT_TRUE(client.setConfiguration(config));
}

/// ~reset forgets the result too (13): the map and paths are withdrawn, ~result says so, and
/// ~save refuses until a new result exists.
TEST_F(Live, ResetWithdrawsTheResultAndSaveRefuses) {
  publishDrive();
  ASSERT_TRUE(callWhenComplete().success);
  const ros::Time before = ros::Time::now();
  // It says what it forgot: at least the drive (earlier tests' drives may be there too).
  std::size_t fixes = 0, poses = 0;
  const std::string said = reset();
  ASSERT_EQ(
      std::sscanf(said.c_str(), "cleared %zu fixes, %zu poses and the result", &fixes, &poses), 2)
      << said;
  EXPECT_GE(fixes, drive_->fixes.size());
  EXPECT_GE(poses, drive_->slam.size());
  EXPECT_EQ(reset(), "cleared 0 fixes, 0 poses and the result");  // nothing came in between
  const auto empty = mapAfter(before, 10.0);
  ASSERT_TRUE(empty);
  EXPECT_EQ(empty->width * empty->height, 0u);
  const auto path = messageWhere<nav_msgs::Path>(
      "/flexcloud/path_rubbersheet", [](const nav_msgs::Path& p) { return p.poses.empty(); }, 10.0);
  EXPECT_TRUE(path) << "the path was not withdrawn";
  const auto msg = resultWhere(before, [](const Result& m) { return !m.has_result; });
  ASSERT_TRUE(msg);
  EXPECT_TRUE(msg->parameters.empty());
  EXPECT_FALSE(msg->success);
  EXPECT_EQ(msg->message, "reset: no result yet: call ~georeference");
  flexcloud::Save save;
  save.request.directory = (fs::temp_directory_path() / "flexcloud_after_reset").string();
  save = callService("/flexcloud/save", save);
  EXPECT_FALSE(save.response.success);
  EXPECT_NE(save.response.message.find("no result to save"), std::string::npos)
      << save.response.message;
  EXPECT_FALSE(fs::exists(save.request.directory));
}

/// ~save with a relative folder writes into the node's working folder and names the absolute
/// path it wrote (13).
TEST_F(Live, SaveWithARelativeFolderNamesTheAbsolutePath) {
  publishDrive();
  ASSERT_TRUE(callWhenComplete().success);
  flexcloud::Save save;
  save.request.directory = "flexcloud_relative_save_" + std::to_string(::getpid());
  save = callService("/flexcloud/save", save);
  ASSERT_TRUE(save.response.success) << save.response.message;
  const std::string prefix = "wrote the result into ";
  ASSERT_EQ(save.response.message.rfind(prefix, 0), 0u) << save.response.message;
  const fs::path dir = save.response.message.substr(prefix.size());
  EXPECT_TRUE(dir.is_absolute()) << dir;
  EXPECT_EQ(dir.filename(), save.request.directory);
  EXPECT_TRUE(fs::exists(dir / "report.json"));
  EXPECT_TRUE(fs::exists(dir / "map_georeferenced.pcd"));
  const pcl::PCLPointCloud2 saved = readPcd((dir / "map_georeferenced.pcd").string());
  EXPECT_EQ(saved.fields.back().name, "sigma_v");  // point_sigma (live.test)
  fs::remove_all(dir);
}

/// ~load_map replaces the map to warp without a restart (13); a file that cannot be read is a
/// one-line failure that leaves the map in use.
TEST_F(Live, LoadMapReplacesTheMapToWarp) {
  publishDrive();
  ASSERT_TRUE(callWhenComplete().success);
  const fs::path file =
      fs::temp_directory_path() / ("flexcloud_load_" + std::to_string(::getpid()) + ".pcd");
  const pcl::PCLPointCloud2 full = sim::slamCloud(drive_->map);
  pcl::PCLPointCloud2 half = full;
  half.width = full.width / 2;
  half.height = 1;
  half.row_step = half.width * half.point_step;
  half.data.resize(static_cast<std::size_t>(half.row_step));
  writePcdBinary(file.string(), half);
  flexcloud::LoadMap missing;
  missing.request.file = "/nonexistent/map.pcd";
  missing = callService("/flexcloud/load_map", missing);
  EXPECT_FALSE(missing.response.success);
  EXPECT_NE(missing.response.message.find("/nonexistent/map.pcd"), std::string::npos);
  flexcloud::LoadMap load;
  load.request.file = file.string();
  load = callService("/flexcloud/load_map", load);
  ASSERT_TRUE(load.response.success) << load.response.message;
  EXPECT_EQ(load.response.points, half.width);
  EXPECT_NE(load.response.message.find("call ~georeference to warp it (the published map is the "
                                       "earlier one)"),
            std::string::npos)
      << load.response.message;
  const auto r = call();
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.map_points, half.width);
  fs::remove(file);
  // The live map topic takes over again with the next message on it.
  publishDrive();
  EXPECT_EQ(callWhenComplete().map_points, drive_->map.slam.size());
}

/// A map whose points carry their scan's time (as a LiDAR SLAM saves it): each point is moved
/// with its own pose, the answer names the field, and the published map lies on its truth with
/// its point sigmas (point_sigma is on in live.test) in centimetres.
TEST_F(Live, AMapWhosePointsKnowTheirTimeIsRebuiltFromTheirPoses) {
  publishDrive();
  ASSERT_TRUE(callWhenComplete().success);
  EXPECT_EQ(call().map_pose_field, "");
  Cloud timed;
  ros_conv::toCloudMsg(sim::slamCloud(drive_->map, true), "map", timed);
  map_pub_.publish(timed);
  ASSERT_EQ(callUntil([](const flexcloud::Georeference::Response& a) {
              return a.success && a.map_pose_field == "time";
            }).map_pose_field,
            "time");
  const ros::Time before = ros::Time::now();  // the map of the next call (the timed one's)
  const auto r = call();
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.map_pose_field, "time");
  EXPECT_EQ(r.map_points, drive_->map.slam.size());
  EXPECT_EQ(r.points_outside, 0u);
  const auto map = mapAfter(before, 20.0);
  ASSERT_TRUE(map);
  const ErrorStats e = againstTruth(*map, sim::truthCloud(drive_->map));
  std::printf("live, rebuilt: map vs truth RMSE %.3f m, MAX %.3f m\n", e.rmse, e.max);
  EXPECT_LE(e.rmse, 0.25);
  // Its point sigmas (point_sigma is on in live.test) hold the truth: 95 % of the points within
  // 2.45 sigma_h horizontally.
  ASSERT_EQ(map->fields.back().name, "sigma_v");
  const pcl::PCLPointCloud2 truth = sim::truthCloud(drive_->map);
  std::size_t within = 0;
  const std::size_t n = drive_->map.slam.size();
  for (std::size_t i = 0; i < n; ++i) {
    float p[3], h;
    double t[3];
    std::memcpy(p, map->data.data() + i * map->point_step, 12);
    std::memcpy(&h, map->data.data() + i * map->point_step + map->fields.back().offset - 4, 4);
    std::memcpy(t, truth.data.data() + i * truth.point_step, 24);
    within += std::hypot(p[0] - t[0], p[1] - t[1]) <= 2.45 * h ? 1 : 0;
  }
  const double share = 100.0 * static_cast<double>(within) / static_cast<double>(n);
  std::printf("live, rebuilt: %.1f %% of the points within 2.45 sigma_h\n", share);
  EXPECT_GE(share, 90.0);
}

/// Publishes each scan in `frame`, stamped with its pose's stamp.
void publishScans(ros::Publisher& pub,
                  const std::vector<std::pair<Pose, pcl::PCLPointCloud2>>& scans,
                  const std::string& frame) {
  std::size_t k = 0;
  for (const auto& [pose, scan] : scans) {
    Cloud msg;
    ros_conv::toCloudMsg(scan, frame, msg);
    msg.header.stamp = ros_conv::toTime(pose.stamp);
    pub.publish(msg);
    if (++k % 500 == 0) ros::WallDuration(0.05).sleep();  // stay within the queues
  }
}

/// The SLAM's registered scans on `scans` (one PointCloud2 a pose, in the map frame): the map
/// is made of them, each point rebuilt with its scan's pose, and lies on its truth; ~reset
/// forgets them with the drive.
TEST_F(Live, RegisteredScansMakeTheMapRebuiltFromTheirPoses) {
  ros::NodeHandle nh;
  ros::Publisher scans = nh.advertise<Cloud>("/scans", 10000);
  ASSERT_TRUE(subscribed({&scans}, 20.0));
  // Once the node has every scan: the map they make, published after one more call, against
  // its truth.
  const auto mapOfTheScans = [this](const char* what) -> std::optional<ErrorStats> {
    const auto r = callUntil([this](const flexcloud::Georeference::Response& a) {
      return a.success && a.map_pose_field == "scan_time" &&
             a.map_points == drive_->map.slam.size();
    });
    EXPECT_TRUE(r.success) << what << ": " << r.message;
    EXPECT_EQ(r.map_pose_field, "scan_time") << what;
    EXPECT_EQ(r.map_points, drive_->map.slam.size()) << what;
    EXPECT_EQ(r.points_outside, 0u) << what;
    const ros::Time before = ros::Time::now();
    EXPECT_TRUE(call().success) << what;
    const auto map = mapAfter(before, 20.0);
    if (!map) return std::nullopt;
    const ErrorStats e = againstTruth(*map, sim::truthCloud(drive_->map));
    std::printf("live, %s: map vs truth RMSE %.3f m, MAX %.3f m\n", what, e.rmse, e.max);
    return e;
  };
  publishDrive();
  publishScans(scans, sim::registeredScans(*drive_), "map");
  const std::optional<ErrorStats> e = mapOfTheScans("registered scans");
  ASSERT_TRUE(e);
  EXPECT_LE(e->rmse, 0.1);
  reset();  // the scans go with the drive: the next test's map is the map topic's again
  // The same scans as the LiDAR saw them, in the odometry's body frame: placed by its poses.
  publishDrive();
  publishScans(scans, sim::keyframeClouds(*drive_), "base_link");
  const std::optional<ErrorStats> b = mapOfTheScans("body-frame scans");
  ASSERT_TRUE(b);
  EXPECT_LE(b->rmse, 1.05 * e->rmse);
  reset();
}

/// A map message whose data holds fewer bytes than its points need (point_sigma is on in
/// live.test: the map is widened for the sigmas): the call fails naming the topic and the sizes,
/// and the node goes on with the next good map.
TEST_F(Live, AMapMessageShortOfItsPointsIsNamed) {
  publishDrive();
  ASSERT_TRUE(callWhenComplete().success);
  Cloud cut;
  ros_conv::toCloudMsg(sim::slamCloud(drive_->map), "map", cut);
  const std::size_t need = cut.data.size();
  cut.data.resize(need / 2);
  map_pub_.publish(cut);
  const auto r = callUntil([](const flexcloud::Georeference::Response& a) { return !a.success; });
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("/map: data holds " + std::to_string(need / 2) + " bytes, but " +
                           std::to_string(drive_->map.slam.size()) + " points of " +
                           std::to_string(cut.point_step) + " bytes need " + std::to_string(need)),
            std::string::npos)
      << r.message;
  publishDrive();
  EXPECT_TRUE(callWhenComplete().success);
}

/// A quarter of the drive published with the whole map (a bag still playing): the call fails
/// saying how much of the map the poses cover; accepted (accept_degraded), the result is
/// mostly outside the GNSS coverage and says so (11): the response, ~result and the log carry
/// a warning with the share.
TEST_F(Live, AMostlyRigidResultCarriesAWarningWithTheShare) {
  reset();
  publishDrive(0.25);
  flexcloud::Georeference::Response r = callUntil(
      [](const auto& a) { return a.message.find("the poses cover") != std::string::npos; });
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.message.rfind("the result cannot be right: the poses cover ", 0), 0u) << r.message;
  EXPECT_NE(r.message.find(" % of the map (within 50 m): is the drive complete? (a bag still "
                           "playing has given part of its poses)"),
            std::string::npos)
      << r.message;
  dynamic_reconfigure::Client<flexcloud::GeoreferenceConfig> client("/flexcloud");
  flexcloud::GeoreferenceConfig config;
  ASSERT_TRUE(client.getCurrentConfiguration(config, ros::Duration(10.0)));
  config.accept_degraded = true;
  ASSERT_TRUE(client.setConfiguration(config));
  const ros::Time before = ros::Time::now();
  r = callUntil([](const auto& a) { return a.success && a.map_points == drive_->map.slam.size(); });
  ASSERT_TRUE(r.success) << r.message;
  ASSERT_FALSE(r.warnings.empty());
  bool found = false;
  for (const auto& w : r.warnings) {
    found = found || w.find("of the map points lie beyond the GNSS coverage") != std::string::npos;
  }
  EXPECT_TRUE(found) << r.message;
  EXPECT_NE(r.message.find("warning: "), std::string::npos);
  EXPECT_GT(r.points_outside, drive_->map.slam.size() / 10);
  const auto msg = resultWhere(before, [](const Result& m) { return m.has_result; });
  ASSERT_TRUE(msg);
  EXPECT_EQ(msg->warnings, r.warnings);
  reset();  // no result left to recompute when the parameter goes back
  config.accept_degraded = false;
  EXPECT_TRUE(client.setConfiguration(config));
}

/// Fixes with latitude and longitude swapped (a driver that wrote them the other way round):
/// ~georeference fails naming it, and no result is published.
TEST_F(Live, SwappedLatitudeAndLongitudeAreNamed) {
  reset();
  publishDrive(1.0, "gnss", true);
  const flexcloud::Georeference::Response r =
      callUntil([](const auto& a) { return a.message.find("swapped") != std::string::npos; });
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.message.rfind("GNSS: latitude and longitude look swapped: the SLAM's track fits "
                            "the fixes to ",
                            0),
            0u)
      << r.message;
  reset();
}

/// Without a transform from the body to the fixes' frame the lever arm parameters apply, and the
/// result says so, naming the frames (the node logs it too).
TEST_F(Live, WithoutTheLeverArmsTfTheParametersApplyAndTheResultSaysSo) {
  reset();
  ros::NodeHandle nh;
  std::vector<rosgraph_msgs::Log> told;
  std::mutex told_mutex;
  const ros::Subscriber rosout =
      nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000, [&](const rosgraph_msgs::LogConstPtr& m) {
        if (m->msg.find("no TF from base_link to antenna_without_tf") == std::string::npos) return;
        const std::lock_guard<std::mutex> lock(told_mutex);
        told.push_back(*m);
      });
  publishDrive(1.0, "antenna_without_tf");
  callWhenComplete();
  const auto r = call();  // a second run: the missing TF is not told again
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(
      r.lever_arm_source.rfind(
          "parameters (0.000, 0.000, 0.000) m: no TF from base_link to antenna_without_tf", 0),
      0u)
      << r.lever_arm_source;
  EXPECT_NEAR(r.lever_arm.x, 0.0, 1e-9);
  std::printf("no lever arm given: antenna offset %s (%.3f, %.3f) m\n",
              r.antenna_offset_estimated ? "estimated" : "not estimated", r.antenna_offset.x,
              r.antenna_offset.y);
  ros::WallDuration(1.0).sleep();  // the log on its way
  const std::lock_guard<std::mutex> lock(told_mutex);
  ASSERT_EQ(told.size(), 1u) << "the missing TF is told once, not on every run";
  EXPECT_EQ(told[0].level, rosgraph_msgs::Log::INFO);
  EXPECT_EQ(told[0].msg,
            "/flexcloud: no TF from base_link to antenna_without_tf: the antenna is taken at the "
            "body's origin (publish the TF or set lever_arm_x/y/z if it is not)");
}

}  // namespace
}  // namespace flexcloud::test
