// georeference.launch in bag mode (bag.test): the nodelet reads the bag itself through the
// same handlers as the live topics, georeferences when it is read, and saves.
#include <std_srvs/Trigger.h>
#include <tf2_ros/transform_listener.h>

#include <filesystem>

#include "flexcloud/FromLL.h"
#include "flexcloud/Save.h"
#include "flexcloud/ToEnu.h"
#include "flexcloud/ToLL.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/io/text_io.h"
#include "ros_test_util.h"

namespace flexcloud::test {
namespace {

namespace fs = std::filesystem;

/// The node reads ~bag itself through the same handlers. The bag holds /gnss/fix and
/// /slam/odom while the node listens on fix and odom (10): it takes the bag's only topics of
/// those types.
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

  const std::string out =
      (fs::temp_directory_path() / ("flexcloud_save_" + std::to_string(getpid()))).string();
  flexcloud::Save save;
  save.request.directory = out;
  ASSERT_TRUE(callOver("/flexcloud/save", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  for (const char* f : {"map_georeferenced.pcd", "report.json", "origin.yaml", "control_points.txt",
                        "trajectory_rubbersheet.txt"}) {
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  }
  const pcl::PCLPointCloud2 saved = readPcd(out + "/map_georeferenced.pcd");
  EXPECT_EQ(saved.width * saved.height, truth.width * truth.height);
  EXPECT_FALSE(fs::exists(out + "/autoware"));
  // The same folder again with the Autoware map and the LAS asked for in the call.
  save.request.autoware = true;
  save.request.las = true;
  ASSERT_TRUE(callOver("/flexcloud/save", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  for (const char* f : {"autoware/map_projector_info.yaml", "autoware/pointcloud_map_metadata.yaml",
                        "map_georeferenced.las", "trajectories.geojson"}) {
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  }
  std::size_t tiled = 0;
  for (const auto& tile : fs::directory_iterator(out + "/autoware/pointcloud_map")) {
    const pcl::PCLPointCloud2 t = readPcd(tile.path().string());
    tiled += t.width * t.height;
  }
  EXPECT_EQ(tiled, truth.width * truth.height);
  fs::remove_all(out);

  // A reset withdraws the result and reads the bag again (13): the map disappears, then the
  // same georeferenced map comes back (georeference_on_bag_end).
  const ros::Time before = ros::Time::now();
  const auto reset = callService<std_srvs::Trigger>("/flexcloud/reset");
  EXPECT_TRUE(reset.response.success);
  EXPECT_NE(reset.response.message.find("reading"), std::string::npos) << reset.response.message;
  EXPECT_TRUE(resultWhere(before, [](const Result& m) { return !m.has_result; }));
  const auto again = mapAfter(before, 60.0);
  ASSERT_TRUE(again);
  const auto back = again->width * again->height > 0 ? again : mapAfter(again->header.stamp, 60.0);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->width * back->height, truth.width * truth.height);
  EXPECT_NEAR(againstTruth(*back, truth).rmse, e.rmse, 1e-9);
}

/// ~to_ll, ~from_ll and ~to_enu (issue 10) on the running node: SLAM poses go through the sheet
/// onto the truth (to_enu), to WGS84 and back into the map frame within 1 mm; the enu frame
/// skips the sheet; a bad frame or a point the sheet cannot reach is answered with the reason.
/// Without map_file, the bag's own map (bag_map.test: the drive's bag holds it on /map) is the
/// node's map: the map published after the bag is read is the drive's, georeferenced.
TEST(BagMap, TheBagsOwnMapIsTakenWithoutAMapFile) {
  ros::NodeHandle pnh("~");
  std::string drive;
  ASSERT_TRUE(pnh.getParam("drive", drive));
  const auto map = mapAfter(ros::Time(0), 60.0);
  ASSERT_TRUE(map) << "no map published: the bag's own map was not taken";
  const pcl::PCLPointCloud2 truth = readPcd(drive + "/truth_map.pcd");
  EXPECT_EQ(map->width * map->height, truth.width * truth.height);
  const ErrorStats e = againstTruth(*map, truth);
  std::printf("bag's own map: map vs truth RMSE %.3f m\n", e.rmse);
  EXPECT_LE(e.rmse, 0.25);
}

TEST(Bag, LatLonServicesRoundTripThroughTheSheet) {
  ros::NodeHandle pnh("~");
  std::string drive;
  ASSERT_TRUE(pnh.getParam("drive", drive));
  ASSERT_TRUE(mapAfter(ros::Time(0), 60.0));  // a result is there
  const Trajectory slam = readTumFile(drive + "/slam_trajectory.txt");
  const Trajectory truth = readTumFile(drive + "/truth_trajectory.txt");
  ASSERT_EQ(slam.size(), truth.size());
  flexcloud::ToEnu to_enu;
  for (std::size_t i = 0; i < slam.size(); i += slam.size() / 20) {
    geometry_msgs::Pose p;
    p.position.x = slam[i].position.x();
    p.position.y = slam[i].position.y();
    p.position.z = slam[i].position.z();
    p.orientation.w = 1.0;
    to_enu.request.poses.push_back(p);
  }
  to_enu = callService("/flexcloud/to_enu", to_enu);
  ASSERT_TRUE(to_enu.response.success) << to_enu.response.message;
  ASSERT_EQ(to_enu.response.poses.size(), to_enu.request.poses.size());
  for (std::size_t k = 0; k < to_enu.response.poses.size(); ++k) {
    const std::size_t i = k * (slam.size() / 20);
    const auto& q = to_enu.response.poses[k].position;
    // The bag's datum is the simulator's, so the truth is in the same ENU frame.
    EXPECT_LT((Eigen::Vector3d(q.x, q.y, q.z) - truth[i].position).norm(), 0.3) << "pose " << i;

    flexcloud::ToLL to_ll;
    to_ll.request.map_point = to_enu.request.poses[k].position;
    to_ll = callService("/flexcloud/to_ll", to_ll);
    ASSERT_TRUE(to_ll.response.success) << to_ll.response.message;
    EXPECT_EQ(to_ll.response.message, "") << "a pose of the drive is inside the sheet";
    flexcloud::FromLL from_ll;
    from_ll.request.ll_point = to_ll.response.ll_point;
    from_ll = callService("/flexcloud/from_ll", from_ll);
    ASSERT_TRUE(from_ll.response.success) << from_ll.response.message;
    const auto& back = from_ll.response.map_point;
    const auto& sent = to_ll.request.map_point;
    EXPECT_LT(std::hypot(back.x - sent.x, back.y - sent.y, back.z - sent.z), 1e-3) << "pose " << i;

    // In the enu frame the sheet is skipped: the ENU of to_enu comes back.
    flexcloud::FromLL enu;
    enu.request.ll_point = to_ll.response.ll_point;
    enu.request.frame = "enu";
    enu = callService("/flexcloud/from_ll", enu);
    ASSERT_TRUE(enu.response.success) << enu.response.message;
    EXPECT_LT(std::hypot(enu.response.map_point.x - q.x, enu.response.map_point.y - q.y,
                         enu.response.map_point.z - q.z),
              1e-3);
  }
  // The top-down view of the rviz configuration looks at enu_view: the middle of the drive.
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  const auto view = buffer.lookupTransform("enu", "enu_view", ros::Time(0), ros::Duration(10.0));
  Eigen::Vector3d lo = truth.front().position, hi = lo;
  for (const auto& p : truth) {
    lo = lo.cwiseMin(p.position);
    hi = hi.cwiseMax(p.position);
  }
  EXPECT_NEAR(view.transform.translation.x, (lo.x() + hi.x()) / 2, 1.0);
  EXPECT_NEAR(view.transform.translation.y, (lo.y() + hi.y()) / 2, 1.0);

  flexcloud::ToLL bad;
  bad.request.frame = "base_link";
  bad = callService("/flexcloud/to_ll", bad);
  EXPECT_FALSE(bad.response.success);
  EXPECT_NE(bad.response.message.find("base_link"), std::string::npos) << bad.response.message;
  // A point 100 km from the drive is answered, with a note that it got the rigid part only.
  flexcloud::ToLL outside;
  outside.request.map_point.x = slam.front().position.x() + 100000.0;
  outside.request.map_point.y = slam.front().position.y();
  outside = callService("/flexcloud/to_ll", outside);
  EXPECT_TRUE(outside.response.success);
  const std::string note = "beyond the rubber sheet, ";
  const std::size_t at = outside.response.message.find(note);
  ASSERT_NE(at, std::string::npos) << outside.response.message;
  const double km = std::stod(outside.response.message.substr(at + note.size()));
  EXPECT_GT(km, 95.0) << outside.response.message;  // the drive is a few km long
  EXPECT_LT(km, 100.5) << outside.response.message;
  flexcloud::FromLL far;
  far.request.ll_point.latitude = 91.0;
  far = callService("/flexcloud/from_ll", far);
  EXPECT_FALSE(far.response.success);
  EXPECT_FALSE(far.response.message.empty());
}

}  // namespace
}  // namespace flexcloud::test
