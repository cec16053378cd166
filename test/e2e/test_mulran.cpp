// Real LiDAR odometry of another family against the truth (../shared/data/mulran_lo: six MulRan
// drives, 4-7 km each, SiMpLE odometry without loop closure that fails outright in places, the
// GNSS simulated from the truth), judged at the true instants: each drive's truth rows lie
// 38-58 ms off its poses (study::knownLag). Nothing was tuned on these drives' figures but what
// the KITTI drives and the simulated ones asked for as well. Each test skips with a message
// where the data is absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "flexcloud/georeference.h"
#include "real_drive.h"
#include "truth_drives.h"

namespace flexcloud {
namespace {

const std::vector<std::string> kDrives = {"DCC_02",   "DCC_03",       "KAIST_02",
                                          "KAIST_03", "Riverside_02", "Riverside_03"};

// Honest RTK GNSS (2 cm, std-devs exactly right): the defaults' horizontal RMSE and MAX at most
// fusion: false's plus 10 % plus 1 cm on every drive (0.027-0.099 m RMSE against 0.085-0.460),
// at most 1 % of the fixes rejected, the first and last 20 s no worse than the middle, the clock
// within 15 ms of the truth (0.8-11.9 ms). The truth, and so the GNSS, lies 1.5-1.7 m ahead of
// the SLAM's origin on these drives (MulRan's base frame, not its LiDAR): the antenna offset is
// estimated (no lever arm is given), and the clock no longer trades with it (before: 0.064-0.153
// m RMSE, the clock 4-20 ms off). The heading profile, taken again with that antenna, agrees with
// the speed profile on every drive and lies within 25 ms of the truth (-10 to +20 ms; 150-300 ms
// off with the poses' origin's course).
TEST(MulranDrives, HonestRtkGnssIsFollowedAtLeastAsCloselyAsBySheetAlone) {
  const std::vector<std::string> dirs = test::findTruthDrives("mulran_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "mulran_lo");
  for (const auto& dir : dirs) {
    const study::TruthDrive d = study::loadTruthDrive(dir, "rtk");
    const GeoreferenceResult r = georeference(d.input, Params{});
    const study::TruthScore s = study::scoreAgainstTruth(d, r);
    const study::TruthScore f =
        study::scoreAgainstTruth(d, georeference(d.input, study::simpleWay()));
    const double clock_error = r.clock_offset + d.lag;  // the truth is -lag
    std::printf(
        "%s: defaults %.3f / %.3f m (ends %.3f, elsewhere %.3f), fusion: false %.3f / %.3f m; "
        "%zu of %zu fixes rejected, clock %+.1f ms off\n",
        d.name.c_str(), s.rmse, s.max, s.ends_max, s.middle_max, f.rmse, f.max, s.rejected, s.fixes,
        1e3 * clock_error);
    EXPECT_LE(s.rmse, 1.1 * f.rmse + 0.01) << d.name;
    EXPECT_LE(s.max, 1.1 * f.max + 0.01) << d.name;
    EXPECT_LE(s.rejected, s.fixes / 100) << d.name;
    EXPECT_LE(s.ends_max, s.middle_max) << d.name;
    EXPECT_LE(std::abs(clock_error), 0.015) << d.name;
    ASSERT_TRUE(r.fusion.has_value());
    const ClockEstimate& c = r.fusion->clock;
    std::printf("  heading profile %+.1f ms off the truth, speed profile %+.1f\n",
                1e3 * (c.heading.offset + d.lag), 1e3 * (c.speed.offset + d.lag));
    EXPECT_TRUE(c.heading.observable) << d.name;
    EXPECT_FALSE(c.disagree) << d.name;
    EXPECT_LE(std::abs(c.heading.offset + d.lag), 0.025) << d.name;
  }
}

// Where the odometry fails (Riverside_02, 580.6-647.8 s: its shape 8.1 m from the GNSS), the fixes
// claim 2 cm, agree with each other and run on without a step, a gap or a change of claim: they
// are followed, and a warning names the SLAM's failure, where and how far.
TEST(MulranDrives, ASlamFailureUnderPreciseGnssIsFollowedAndNamed) {
  const std::string dir = test::findTruthDrive("mulran_lo/Riverside_02");
  if (dir.empty()) GTEST_SKIP() << "mulran_lo/Riverside_02 not found; skipped";
  const study::TruthDrive d = study::loadTruthDrive(dir, "rtk");
  const GeoreferenceResult r = georeference(d.input, Params{});
  ASSERT_TRUE(r.fusion.has_value());
  const auto& failures = r.fusion->follow.slam_failures;
  ASSERT_FALSE(failures.empty());
  bool named = false;
  for (const auto& w : resultWarnings(r, Params{}, nullptr)) {
    double from = 0.0, to = 0.0;
    if (std::sscanf(w.c_str(), "SLAM failure: from %lf to %lf s", &from, &to) == 2) {
      std::printf("%s\n", w.c_str());
      named = named || (std::abs(from - 580.6) < 1.0 && std::abs(to - 647.8) < 3.0);
    }
    EXPECT_EQ(w.find("disputed between the GNSS and the SLAM"), std::string::npos) << w;
  }
  EXPECT_TRUE(named);
  double worst = 0.0;
  for (std::size_t i = 0; i < r.rubbersheet.size(); ++i) {
    const double t = d.input.poses[i].stamp;
    if (t < 580.0 || t > 651.0) continue;
    worst =
        std::max(worst, (r.rubbersheet[i].position - d.truth_at_pose[i].position).head<2>().norm());
  }
  std::printf("Riverside_02 rtk, 580-651 s: at most %.3f m from the truth (the SLAM 8.1 m)\n",
              worst);
  EXPECT_LT(worst, 0.4);
}

// Urban GNSS (1 Hz, 0.3 m, multipath, outliers, no std-dev): of the fixes more than 3 m off the
// truth, at least 90 % are rejected (all, on every drive). The targets aimed at (0.60 / 3.0 m)
// are met on five drives (0.187-0.573 m RMSE, 0.74-2.11 m MAX), not on Riverside_02 (2.143 /
// 9.51 m), whose odometry fails for 70 s (580-650 s) where code-grade fixes cannot tell a SLAM
// failure from a multipath episode. The figures recorded are held within 10 % (before the antenna
// offset was estimated: 0.615-2.563 m RMSE, 2.11-9.98 m MAX). KAIST_02, KAIST_03 and Riverside_02
// start at a standstill where the odometry moves before the car (drive_ends.h): their first
// fixes, rejected by the graph, are followed, and their first 20 s lie within the MAX of their
// middle (0.46, 0.68 and 0.84 m; 2.57, 1.58 and 2.02 m before, over KAIST_02's and KAIST_03's).
TEST(MulranDrives, UrbanGnssIsBridgedAsRecorded) {
  const std::vector<std::string> dirs = test::findTruthDrives("mulran_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "mulran_lo");
  const std::vector<std::pair<double, double>> recorded = {{0.413, 0.941}, {0.573, 2.028},
                                                           {0.499, 2.107}, {0.366, 1.490},
                                                           {2.143, 9.505}, {0.187, 0.742}};
  const std::vector<std::string> standstill_start = {"KAIST_02", "KAIST_03", "Riverside_02"};
  for (std::size_t k = 0; k < dirs.size(); ++k) {
    const study::TruthDrive d = study::loadTruthDrive(dirs[k], "urban");
    const std::size_t at = static_cast<std::size_t>(
        std::find(kDrives.begin(), kDrives.end(), std::filesystem::path(dirs[k]).filename()) -
        kDrives.begin());
    const GeoreferenceResult r = georeference(d.input, Params{});
    const study::TruthScore s = study::scoreAgainstTruth(d, r);
    std::printf("%s\n", study::describeScore(d.name, s).c_str());
    EXPECT_LE(s.rmse, 1.1 * recorded[at].first) << d.name;
    EXPECT_LE(s.max, 1.1 * recorded[at].second) << d.name;
    EXPECT_GE(static_cast<double>(s.far_rejected), 0.9 * static_cast<double>(s.far)) << d.name;
    const std::string drive = std::filesystem::path(dirs[k]).filename().string();
    if (std::find(standstill_start.begin(), standstill_start.end(), drive) !=
        standstill_start.end()) {
      EXPECT_LE(s.ends_max, s.middle_max) << d.name;
      EXPECT_LT(s.ends_max, 0.9) << d.name;
      // Told: the SLAM's start, where and how far.
      ASSERT_TRUE(r.fusion.has_value());
      ASSERT_EQ(r.fusion->drive_ends_followed.size(), 1u) << d.name;
      EXPECT_LT(r.fusion->drive_ends_followed[0].begin, d.input.poses.front().stamp + 1.0);
      EXPECT_GT(r.fusion->drive_ends_followed[0].worst, 1.0) << d.name;
      std::size_t told = 0;
      for (const auto& w : resultWarnings(r, Params{}, nullptr)) {
        told += w.rfind("SLAM at an end of the drive: from ", 0) == 0;
      }
      EXPECT_EQ(told, 1u) << d.name;
    } else {
      EXPECT_TRUE(!r.fusion || r.fusion->drive_ends_followed.empty()) << d.name;
    }
  }
}

/// The pose sigmas of every drive with GNSS of `kind`: pooled, 85 % to `most_h` of the poses
/// within 2.45 sigma_h and 85 % to `most_v` within 1.96 sigma_v, at least 75 % on every drive.
void expectSigmasCover(const std::vector<std::string>& dirs, const char* kind, double most_h,
                       double most_v) {
  std::vector<study::CalibrationRow> rows;
  sim::SigmaCoverage pooled;
  for (const auto& dir : dirs) {
    const study::TruthDrive d = study::loadTruthDrive(dir, kind);
    const GeoreferenceResult r = georeference(d.input, Params{});
    const sim::SigmaCoverage c = study::sigmaCoverage(d, r);
    rows.push_back({d.name, c, r.sigma.median_h, study::scoreAgainstTruth(d, r).rmse});
    pooled += c;
    EXPECT_GE(c.shareH(), 0.75) << d.name << " " << kind;
    EXPECT_GE(c.shareV(), 0.75) << d.name << " " << kind;
  }
  study::printCalibrationRows(rows);
  EXPECT_GE(pooled.shareH(), 0.85) << kind;
  EXPECT_LE(pooled.shareH(), most_h) << kind;
  EXPECT_GE(pooled.shareV(), 0.85) << kind;
  EXPECT_LE(pooled.shareV(), most_v) << kind;
}

// With RTK GNSS: 97.7 / 88.0 % pooled, 89.3-100 / 83.9-93.1 % per drive. The antenna's offset,
// estimated, counts along the track with its own sigma and what it trades with the clock (0.08
// m): without, KAIST_03 and Riverside_03 lay 60.7 and 52.1 % within.
TEST(MulranDrives, PoseSigmasCoverTheErrorsWithRtkGnss) {
  const std::vector<std::string> dirs = test::findTruthDrives("mulran_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "mulran_lo");
  expectSigmasCover(dirs, "rtk", 0.99, 0.99);
}

// With urban GNSS (1 Hz, no std-dev): 96.9-100 / 98.7-100 % per drive, pooled 98.8 / 99.5 %.
// Where the fixes are imprecise the horizontal walk counts unweighted (pose_sigma.cpp): with the
// weight of precise fixes (1.25) 99.3 % lay within, more cautious than the 99 % aimed at.
// Median sigma_h 0.21-0.31 m against an RMSE of 0.19-0.57 m (Riverside_02, whose odometry
// fails: 0.52 against 2.15). Vertically still more cautious than 99 %.
TEST(MulranDrives, PoseSigmasCoverTheErrorsWithUrbanGnss) {
  const std::vector<std::string> dirs = test::findTruthDrives("mulran_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "mulran_lo");
  expectSigmasCover(dirs, "urban", 0.99, 0.996);
}

// The orientations with RTK GNSS against the truth. MulRan's truth is of the car's base, the
// poses of its LiDAR: the rotation that fits each drive best is 1.34-1.76 degrees, about -1.4
// about the body's y axis on all six (the LiDAR pitched on the base), and the truth is turned by
// their median (study::knownMount) before it judges. Then the 95th percentile of the angle is
// 0.39-0.87 degrees on DCC_02, DCC_03, KAIST_02 and Riverside_03 (1.56-1.83 against the base),
// about y 0.32-0.81 and about z 0.28-0.78 everywhere: the heading turned with the path the fixes
// moved the poses onto (KAIST_02 1.18 and Riverside_02 1.96 about z without). What is left the
// fixes do not show: KAIST_03's odometry rolls (2.94 about x), Riverside_02's where it fails
// (1.34 about x).
TEST(MulranDrives, OrientationsWithRtkGnssAgainstTheLidarsOwn) {
  const std::vector<std::string> dirs = test::findTruthDrives("mulran_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "mulran_lo");
  for (const auto& dir : dirs) {
    const study::TruthDrive d = study::loadTruthDrive(dir, "rtk");
    const study::TruthScore s = study::scoreAgainstTruth(d, georeference(d.input, Params{}));
    const std::string seq = std::filesystem::path(dir).filename().string();
    std::printf(
        "%s: orientation p95 %.2f deg against the base, %.2f against the LiDAR (about x / y / z "
        "%.2f / %.2f / %.2f); the best fitting mount %.2f deg, %.2f about y\n",
        d.name.c_str(), s.turn_p95, s.turn_less_mount_p95, s.turn_axes_p95.x(), s.turn_axes_p95.y(),
        s.turn_axes_p95.z(), s.fitted_mount.norm(), s.fitted_mount.y());
    EXPECT_NEAR(s.fitted_mount.y(), d.mount.y(), 0.2) << d.name;
    EXPECT_LE(s.turn_axes_p95.y(), 1.0) << d.name;
    EXPECT_LE(s.turn_axes_p95.z(), 0.9) << d.name;
    if (seq == "DCC_02" || seq == "DCC_03" || seq == "KAIST_02" || seq == "Riverside_03") {
      EXPECT_LE(s.turn_less_mount_p95, 1.0) << d.name;
    }
  }
}

}  // namespace
}  // namespace flexcloud
