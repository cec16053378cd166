// The real drive of ../shared/data/a2rl against the published method's accuracy on it.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "flexcloud/georeference.h"
#include "flexcloud/io/text_io.h"

namespace flexcloud {
namespace {

/// The data folder: $FLEXCLOUD_A2RL_DIR, or shared/data/a2rl beside the repository.
std::string findData() {
  std::vector<std::string> candidates;
  if (const char* env = std::getenv("FLEXCLOUD_A2RL_DIR")) candidates.emplace_back(env);
  candidates.emplace_back(std::string(FLEXCLOUD_SOURCE_DIR) + "/../shared/data/a2rl");
  candidates.emplace_back("/work/shared/data/a2rl");
  for (const auto& c : candidates) {
    if (std::filesystem::exists(c + "/slam_poses_tum.txt")) return c;
  }
  return "";
}

struct Published {
  int control_points;
  double mae, std, max;
};

// The published method on this drive (all 2386 poses; ../shared/data/a2rl/README.md).
constexpr Published kPublished[] = {{10, 2.84, 2.36, 17.61},
                                    {50, 0.87, 2.09, 17.04},
                                    {100, 0.39, 0.90, 10.87},
                                    {200, 0.23, 0.41, 7.44}};

TEST(A2rl, BeatsThePublishedMethodAtEveryControlPointCount) {
  const std::string dir = findData();
  if (dir.empty()) GTEST_SKIP() << "a2rl data not found (set FLEXCLOUD_A2RL_DIR); skipped";
  DriveInput in;
  in.poses = readTumFile(dir + "/slam_poses_tum.txt");
  in.local_gnss = readLocalGnssFile(dir + "/gnss_local_at_poses.txt");
  ASSERT_EQ(in.poses.size(), 2386u);
  for (const Published& pub : kPublished) {
    Params p;
    p.control_points = pub.control_points;
    const GeoreferenceResult r = georeference(in, p);
    const ErrorStats& m = r.metrics_rubbersheet;
    std::printf(
        "a2rl %3d control points: MAE %.3f STD %.3f MAX %.3f m (published %.2f %.2f %.2f)\n",
        pub.control_points, m.mae, m.std, m.max, pub.mae, pub.std, pub.max);
    EXPECT_EQ(r.control_points.points.size(), static_cast<std::size_t>(pub.control_points));
    EXPECT_LE(m.mae, pub.mae) << pub.control_points;
    EXPECT_LE(m.std, pub.std) << pub.control_points;
    EXPECT_LE(m.max, pub.max) << pub.control_points;
    EXPECT_EQ(r.poses_matched, 2386u);  // every pose is evaluated
    // The rigid alignment alone is far off, as the data's README says (MAE 7.14 m).
    EXPECT_NEAR(r.metrics_aligned.mae, 7.2, 0.3);
  }
}

}  // namespace
}  // namespace flexcloud
