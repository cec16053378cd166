// The map is the product: maps made as a LiDAR SLAM makes them from the real KITTI drives (a
// scan every 5th pose, the ground, walls and poles 2-50 m out, placed by the SLAM's poses; their
// truth placed by the true poses), judged against that truth, and the corrected trajectory's
// orientations against the true ones. Skipped with a message where the data is absent.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "flexcloud/georeference.h"
#include "real_drive.h"
#include "truth_drives.h"
#include "truth_maps.h"

namespace flexcloud {
namespace {

const std::vector<std::string> kDrives = {"01", "02", "03", "04", "05", "06", "07", "09", "10"};

// With RTK GNSS, the map each point's own fused pose gives lies within 0.25 m of the truth
// horizontally (0.101-0.209 m). The rubber sheet's map, away from revisits, is as recorded
// (0.126-0.760 m horizontally, 0.104-0.621 vertically): one warp for passes the SLAM holds
// apart. Its points beside the road carry the fused poses' rotation, roll included, out to the
// second ring of points beside (50 m): on 04 (a 400 m straight) the fused roll is 1.6 degrees
// off, and the sheet's map is as far off vertically as the own poses' (0.57 and 0.58 m).
// Held within 10 % of the figures recorded here. The point sigmas (point_sigma.h, default
// model) hold 82-99 % of the points within 2.45 sigma_h within 10 m of their pose; farther out
// as few as 20 % (01, 30-50 m): the model's heading and tilt (0.03 and 0.11 degrees) are the
// simulated SLAM's, and this odometry turns its map by about half a degree. Held within 5
// points of the near band's share recorded here.
TEST(TruthMaps, ALidarsMapAgainstItsTruthWithRtkGnss) {
  struct Recorded {
    const char* drive;
    double away_h, away_v, near_cover;
  };
  const Recorded recorded[] = {
      {"01", 0.215, 0.113, 82.4}, {"02", 0.760, 0.505, 98.7}, {"03", 0.210, 0.104, 95.7},
      {"04", 0.126, 0.573, 91.9}, {"05", 0.328, 0.621, 98.4}, {"06", 0.369, 0.109, 96.0},
      {"07", 0.211, 0.297, 97.8}, {"09", 0.246, 0.291, 99.2}, {"10", 0.172, 0.174, 99.4}};
  bool any = false;
  for (const Recorded& rec : recorded) {
    const std::string dir = test::findTruthDrive(std::string("kitti_lo/") + rec.drive);
    if (dir.empty()) continue;
    any = true;
    const study::TruthDrive d = study::loadTruthDrive(dir, "rtk");
    const GeoreferenceResult r = georeference(d.input, Params{});
    const study::DriveMap m = study::makeDriveMap(d);
    const study::MapScore sheet = study::scoreSheet(m, r);
    const study::MapScore own = study::scoreOwnPose(m, d, r);
    const study::MapScore rebuilt = study::scoreRebuilt(m, d, r);
    const study::SigmaCover cover = study::sheetSigmaCover(m, r, Params{});
    std::printf(
        "%s: %zu points; the sheet %.3f / %.3f m (away from revisits %.3f / %.3f), each point's "
        "own fused pose %.3f / %.3f m (h / v RMSE); within 2.45 sigma_h %.1f / %.1f / %.1f %%\n",
        d.name.c_str(), m.slam.size(), sheet.h.rmse, sheet.v.rmse, sheet.away_h.rmse,
        sheet.away_v.rmse, own.h.rmse, own.v.rmse, cover.band_h[0], cover.band_h[1],
        cover.band_h[2]);
    EXPECT_GE(cover.band_h[0], rec.near_cover - 5.0) << d.name;
    EXPECT_LE(sheet.away_h.rmse, 1.1 * rec.away_h) << d.name;
    EXPECT_LE(sheet.away_v.rmse, 1.1 * rec.away_v) << d.name;
    EXPECT_LT(own.h.rmse, 0.25) << d.name;
    // Each point moved with its nearest pose's correction: the best a warp by place can do. No
    // better than its own pose's; on 01 (a motorway no pass comes back to) as good.
    const study::MapScore nearest = study::scoreNearestPose(m, d, r);
    std::printf("%s: each point's nearest pose, away from revisits %.3f / %.3f m\n", d.name.c_str(),
                nearest.away_h.rmse, nearest.away_v.rmse);
    EXPECT_GE(nearest.away_h.rmse, 0.95 * own.away_h.rmse) << d.name;
    if (std::string(rec.drive) == "01") EXPECT_LE(nearest.away_h.rmse, 1.1 * own.away_h.rmse);
    // Saved with per-point time and rebuilt: as good as each point's own pose, everywhere.
    std::printf("%s: rebuilt from its points' time %.3f / %.3f m (away %.3f / %.3f)\n",
                d.name.c_str(), rebuilt.h.rmse, rebuilt.v.rmse, rebuilt.away_h.rmse,
                rebuilt.away_v.rmse);
    EXPECT_LE(rebuilt.h.rmse, 1.1 * own.h.rmse) << d.name;
    EXPECT_LE(rebuilt.v.rmse, 1.1 * own.v.rmse) << d.name;
    EXPECT_LE(rebuilt.away_h.rmse, 1.1 * own.away_h.rmse) << d.name;
    EXPECT_LE(rebuilt.away_v.rmse, 1.1 * own.away_v.rmse) << d.name;
    for (int b = 0; b < study::kBands; ++b) {
      EXPECT_LE(rebuilt.band_h[b].rmse, 1.1 * own.band_h[b].rmse) << d.name << " band " << b;
      EXPECT_LE(rebuilt.band_v[b].rmse, 1.1 * own.band_v[b].rmse) << d.name << " band " << b;
    }
  }
  if (!any) GTEST_SKIP() << "kitti_lo not found (../shared/data/kitti_lo); skipped";
}

// The corrected trajectory's orientations with RTK GNSS, the 95th percentile of their angle from
// the truth: within 1 degree on eight of the nine drives (0.44-0.93; they take the fused
// trajectory's, where the sheet's own rotation around a pose was 32 degrees off on 05). 04 is a
// 400 m straight, whose roll about the road no fix shows: the keyframes' mean tilt held within
// 2 degrees of the start's keeps it to 1.8 (the graph alone rolled it 11.4 degrees).
TEST(TruthMaps, OrientationsWithRtkGnss) {
  bool any = false;
  for (const auto& seq : kDrives) {
    const std::string dir = test::findTruthDrive("kitti_lo/" + seq);
    if (dir.empty()) continue;
    any = true;
    const study::TruthDrive d = study::loadTruthDrive(dir, "rtk");
    const study::TruthScore s = study::scoreAgainstTruth(d, georeference(d.input, Params{}));
    std::printf("%s: orientation p95 %.2f deg\n", d.name.c_str(), s.turn_p95);
    EXPECT_LE(s.turn_p95, seq == "04" ? 2.0 : 1.0) << d.name;
  }
  if (!any) GTEST_SKIP() << "kitti_lo not found (../shared/data/kitti_lo); skipped";
}

}  // namespace
}  // namespace flexcloud
