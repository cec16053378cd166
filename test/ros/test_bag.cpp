// georeference.launch in bag mode (bag.test): the nodelet reads the bag itself through the
// same handlers as the live topics, georeferences when it is read, and saves.
#include <std_srvs/Trigger.h>

#include <filesystem>

#include "flexcloud/Save.h"
#include "flexcloud/io/pcd_io.h"
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
  ASSERT_TRUE(ros::service::call("/flexcloud/save", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  for (const char* f : {"map_georeferenced.pcd", "report.json", "origin.yaml", "control_points.txt",
                        "trajectory_rubbersheet.txt"}) {
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  }
  const pcl::PCLPointCloud2 saved = readPcd(out + "/map_georeferenced.pcd");
  EXPECT_EQ(saved.width * saved.height, truth.width * truth.height);
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

}  // namespace
}  // namespace flexcloud::test
