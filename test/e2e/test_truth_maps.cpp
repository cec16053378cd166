// The map is the product: maps made as a LiDAR SLAM makes them from the real KITTI drives (a
// scan every 5th pose, the ground, walls and poles 2-50 m out, placed by the SLAM's poses; their
// truth placed by the true poses), judged against that truth, and the corrected trajectory's
// orientations against the true ones. Skipped with a message where the data is absent.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "flexcloud/georeference.h"
#include "real_drive.h"
#include "truth_drives.h"
#include "truth_maps.h"

namespace flexcloud {
namespace {

const std::vector<std::string> kDrives = {"01", "02", "03", "04", "05", "06", "07", "09", "10"};
const char* const kBandNames[study::kBands] = {"0-10", "10-30", "30-50"};

/// The map's expected error the result tells (map_sigma.h) against the map's errors, by band,
/// per axis: the sheet's map below the told 95th percentile and above a quarter of the median
/// (the sheet's sigmas are cautious where its strain is large: on MulRan the median is 1.5-3
/// times the RMSE), the rebuilt map's at most 2.5 times the told root mean square and at least
/// that over `cautious` (the told as cautious as the pose sigmas it starts from may be).
void expectToldHowGood(const std::string& drive, const study::MapScore& sheet,
                       const study::MapScore& rebuilt, const MapSigma& told,
                       double cautious = 2.5) {
  for (int b = 0; b < study::kBands; ++b) {
    const double by_sheet = sheet.band_h[b].rmse / std::sqrt(2.0);
    const double by_pose = rebuilt.band_h[b].rmse / std::sqrt(2.0);
    std::printf(
        "%s, %s m: per axis, the sheet's map %.3f m (told %.3f median, %.3f p95), the "
        "rebuilt map's %.3f m (told %.3f)\n",
        drive.c_str(), kBandNames[b], by_sheet, told.sheet[b].h_median, told.sheet[b].h_p95,
        by_pose, told.own_pose[b].h_rms);
    EXPECT_GE(by_sheet, 0.25 * told.sheet[b].h_median) << drive << " band " << b;
    EXPECT_LE(by_sheet, told.sheet[b].h_p95) << drive << " band " << b;
    EXPECT_GE(by_pose, told.own_pose[b].h_rms / cautious) << drive << " band " << b;
    EXPECT_LE(by_pose, 2.5 * told.own_pose[b].h_rms) << drive << " band " << b;
  }
}

/// The point sigmas of a family's maps hold 85-99 % of the points within 2.45 sigma_h in each
/// band of distance from their pose: the mean of the drives' shares.
void expectCalibrated(const std::vector<study::SigmaCover>& covers, const char* what) {
  for (int b = 0; b < study::kBands; ++b) {
    double sum = 0.0;
    for (const auto& c : covers) sum += c.band_h[b];
    const double mean = sum / static_cast<double>(covers.size());
    std::printf("%s: %.1f %% within 2.45 sigma_h in band %d, the drives' mean\n", what, mean, b);
    EXPECT_GE(mean, 85.0) << what << " band " << b;
    EXPECT_LE(mean, 99.0) << what << " band " << b;
  }
}

// With RTK GNSS, the map each point's own fused pose gives lies within 0.25 m of the truth
// horizontally (0.101-0.209 m). The rubber sheet's map, away from revisits, is as recorded
// (0.126-0.760 m horizontally, 0.104-0.621 vertically): one warp for passes the SLAM holds
// apart. Its points beside the road carry the fused poses' rotation, roll included, out to the
// second ring of points beside (50 m): on 04 (a 400 m straight) the fused roll is 1.6 degrees
// off, and the sheet's map is as far off vertically as the own poses' (0.57 and 0.58 m).
// Held within 10 % of the figures recorded here. The point sigmas (point_sigma.h, default
// model: 4 mrad of heading, the fused orientations' 1-sigma on these drives, whose p95 is
// 0.44-0.93 degrees) hold 85-99 % of the points within 2.45 sigma_h in each band, the mean of the
// nine drives' shares, for the sheet's map (97.1 / 87.4 / 87.1 %) and the rebuilt map's (97.4 /
// 94.0 / 92.8 %); each drive's near band held within 5 points of the share recorded here.
TEST(TruthMaps, ALidarsMapAgainstItsTruthWithRtkGnss) {
  struct Recorded {
    const char* drive;
    double away_h, away_v, near_cover;
  };
  const Recorded recorded[] = {
      {"01", 0.215, 0.113, 91.1}, {"02", 0.760, 0.505, 98.9}, {"03", 0.210, 0.104, 96.2},
      {"04", 0.126, 0.573, 95.4}, {"05", 0.328, 0.621, 98.7}, {"06", 0.369, 0.109, 96.5},
      {"07", 0.211, 0.297, 98.2}, {"09", 0.246, 0.291, 99.5}, {"10", 0.172, 0.174, 99.6}};
  std::vector<study::SigmaCover> sheet_covers, rebuilt_covers;
  for (const Recorded& rec : recorded) {
    const std::string dir = test::findTruthDrive(std::string("kitti_lo/") + rec.drive);
    if (dir.empty()) continue;
    const study::TruthDrive d = study::loadTruthDrive(dir, "rtk");
    const GeoreferenceResult r = georeference(d.input, Params{});
    const study::DriveMap m = study::makeDriveMap(d);
    const study::MapScore sheet = study::scoreSheet(m, r);
    const study::MapScore own = study::scoreOwnPose(m, d, r);
    const study::MapScore rebuilt = study::scoreRebuilt(m, d, r);
    const study::SigmaCover cover = study::sheetSigmaCover(m, r, Params{});
    sheet_covers.push_back(cover);
    expectToldHowGood(d.name, sheet, rebuilt, r.map_sigma);
    rebuilt_covers.push_back(study::rebuiltSigmaCover(m, d, r, Params{}));
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
    // Each point moved with its nearest pose's correction: no better than its own pose's; on 01
    // (a motorway no pass comes back to) as good.
    const study::MapScore nearest = study::scoreNearestPose(m, d, r);
    std::printf("%s: each point's nearest pose, away from revisits %.3f / %.3f m\n", d.name.c_str(),
                nearest.away_h.rmse, nearest.away_v.rmse);
    EXPECT_GE(nearest.away_h.rmse, 0.95 * own.away_h.rmse) << d.name;
    if (std::string(rec.drive) == "01") {
      EXPECT_LE(nearest.away_h.rmse, 1.1 * own.away_h.rmse);
    }
    // The floor of a plain map holds: the sheet, a warp by place, lies above it.
    const study::MapScore floor = study::scoreFloor(study::makeDenseDriveMap(d));
    std::printf("%s: the best warp affine in 5 m cells %.3f / %.3f m (away %.3f / %.3f)\n",
                d.name.c_str(), floor.h.rmse, floor.v.rmse, floor.away_h.rmse, floor.away_v.rmse);
    EXPECT_GE(sheet.h.rmse, floor.h.rmse) << d.name;
    EXPECT_GE(sheet.away_h.rmse, floor.away_h.rmse) << d.name;
    EXPECT_GE(sheet.away_v.rmse, floor.away_v.rmse) << d.name;
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
  if (sheet_covers.empty()) GTEST_SKIP() << "kitti_lo not found (../shared/data/kitti_lo); skipped";
  expectCalibrated(sheet_covers, "the sheet's map");
  expectCalibrated(rebuilt_covers, "the rebuilt map");
}

// The floor of a plain map against known answers: a map the truth takes by one rotation and shift
// has none; two passes whose points the SLAM lays at the same places, needing shifts 2 m apart,
// have 1 m (each pass 1 m from their mean); away from revisits (the second pass flagged) none.
TEST(TruthMaps, TheFloorOfAPlainMapKnownAnswers) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  study::DriveMap one, two;
  for (int k = 0; k < 4000; ++k) {
    const Eigen::Vector3d p(u(rng), u(rng), 0.1 * u(rng));
    one.slam.push_back(p), one.truth.push_back(turn * p + Eigen::Vector3d(300.0, -40.0, 2.0));
    for (double side : {1.0, -1.0}) {
      two.slam.push_back(p), two.truth.push_back(p + Eigen::Vector3d(side, 0.0, 0.0));
      two.revisit.push_back(side < 0.0);
    }
  }
  for (study::DriveMap* m : {&one, &two}) {
    m->pose.assign(m->slam.size(), 0), m->range.assign(m->slam.size(), 5.0F);
    m->revisit.resize(m->slam.size(), false);
  }
  const study::MapScore rigid = study::scoreFloor(one);
  EXPECT_LT(rigid.h.max, 1e-9);
  EXPECT_LT(rigid.v.max, 1e-9);
  const study::MapScore passes = study::scoreFloor(two);
  EXPECT_NEAR(passes.h.rmse, 1.0, 1e-9);
  EXPECT_NEAR(passes.h.max, 1.0, 1e-9);
  EXPECT_LT(passes.v.max, 1e-9);
  EXPECT_LT(passes.away_h.max, 1e-9);
  EXPECT_EQ(passes.away_h.points, 4000U);
}

// On the MulRan drives, whose passes the SLAM holds metres apart (drift of 6-47 m) within 30-50 m
// of each other, no warp by place brings a plain map within 1.5 times the map its points' own
// poses give, away from revisits: the best warp affine within each 5 m cell, fitted to the truth,
// is 0.73-1.88 m off horizontally, where the map rebuilt from its points' time is 0.08-0.23 m.
// The sheet lies above that floor (3.0-9.2 m). Held: the floor at least twice the rebuilt map's.
// Their point sigmas hold 85-99 % within 2.45 sigma_h in each band, the mean of the drives' shares
// (the sheet's map 98.8 / 95.8 / 92.5 %, the rebuilt map's 98.3 / 97.4 / 96.0 %). The truth's
// scans are placed by the LiDAR's true pose (the base's turned by study::knownMount). The told
// error of the rebuilt map is up to 4.1 times its RMSE (DCC_02 near the route): it starts from
// the pose sigmas, 2.5 times the trajectory's RMSE there, the antenna's 8 cm along the track that
// KAIST_03 and Riverside_03 need (MulranDrives.PoseSigmasCoverTheErrorsWithRtkGnss).
TEST(TruthMaps, PlainMulranMapsHaveAFloorFarAboveTheirOwnPosesAndSigmasThatHold) {
  const std::vector<std::string> dirs = test::findTruthDrives(
      "mulran_lo", {"DCC_02", "DCC_03", "KAIST_02", "KAIST_03", "Riverside_02", "Riverside_03"});
  SKIP_WITHOUT_DRIVES(dirs, "mulran_lo");
  std::vector<study::SigmaCover> sheet_covers, rebuilt_covers;
  for (const auto& dir : dirs) {
    const study::TruthDrive d = study::loadTruthDrive(dir, "rtk");
    const GeoreferenceResult r = georeference(d.input, Params{});
    const study::DriveMap m = study::makeDriveMap(d);
    const study::MapScore sheet = study::scoreSheet(m, r);
    const study::MapScore rebuilt = study::scoreRebuilt(m, d, r);
    const study::MapScore floor = study::scoreFloor(study::makeDenseDriveMap(d));
    std::printf("%s: away from revisits, the sheet %.3f m, the floor %.3f m, rebuilt %.3f m\n",
                d.name.c_str(), sheet.away_h.rmse, floor.away_h.rmse, rebuilt.away_h.rmse);
    EXPECT_GE(floor.away_h.rmse, 2.0 * rebuilt.away_h.rmse) << d.name;
    EXPECT_GE(sheet.away_h.rmse, floor.away_h.rmse) << d.name;
    expectToldHowGood(d.name, sheet, rebuilt, r.map_sigma, 4.5);
    sheet_covers.push_back(study::sheetSigmaCover(m, r, Params{}));
    rebuilt_covers.push_back(study::rebuiltSigmaCover(m, d, r, Params{}));
  }
  expectCalibrated(sheet_covers, "the sheet's map");
  expectCalibrated(rebuilt_covers, "the rebuilt map");
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
