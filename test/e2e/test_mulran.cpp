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
// fusion: false's plus 10 % plus 1 cm on every drive (0.064-0.153 m RMSE against 0.085-0.460;
// before, the clock taken from a fit of positions 150-190 ms off and the SLAM's failures
// followed against the GNSS: 0.392-2.024 m), at most 1 % of the fixes rejected, the first and
// last 20 s no worse than the middle. The clock is bounded by the speed profile: within 21 ms of
// the truth (DCC_03, KAIST_02 and KAIST_03's speed profiles lie 11-20 ms from their README's
// lag; the fit of positions, which the SLAM's heading lag in turns moves by 120-190 ms, is held
// at it).
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
    EXPECT_LE(std::abs(clock_error), 0.021) << d.name;
  }
}

// Where the odometry fails (Riverside_02, 580-650 s: its shape 8.6 m from the GNSS), the fixes
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
    named = named || w.rfind("SLAM failure: from 580.5 to 650.5 s", 0) == 0;
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
  std::printf("Riverside_02 rtk, 580-651 s: at most %.3f m from the truth (the SLAM 8.6 m)\n",
              worst);
  EXPECT_LT(worst, 0.4);
}

// Urban GNSS (1 Hz, 0.3 m, multipath, outliers, no std-dev): of the fixes more than 3 m off the
// truth, at least 90 % are rejected (all but 3 of 56 on KAIST_03, all elsewhere). The targets
// aimed at (0.60 / 3.0 m) are not met: these odometries drift by 6-47 m and fail for tens of
// seconds, and with code-grade fixes a SLAM failure and a multipath episode look alike. The
// figures recorded (0.615-2.563 m RMSE, 2.11-2.95 m MAX but Riverside_02's 9.98 m; before the
// clock was bounded by the speed profile, 0.615-2.563 and 2.11-9.98 m) are held within 10 %.
TEST(MulranDrives, UrbanGnssIsBridgedAsRecorded) {
  const std::vector<std::string> dirs = test::findTruthDrives("mulran_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "mulran_lo");
  const std::vector<std::pair<double, double>> recorded = {{0.987, 2.538}, {0.994, 2.561},
                                                           {1.032, 2.953}, {1.085, 2.624},
                                                           {2.563, 9.977}, {0.615, 2.114}};
  for (std::size_t k = 0; k < dirs.size(); ++k) {
    const study::TruthDrive d = study::loadTruthDrive(dirs[k], "urban");
    const std::size_t at = static_cast<std::size_t>(
        std::find(kDrives.begin(), kDrives.end(), std::filesystem::path(dirs[k]).filename()) -
        kDrives.begin());
    const study::TruthScore s = study::scoreAgainstTruth(d, georeference(d.input, Params{}));
    std::printf("%s: %.3f / %.3f m; %zu of %zu fixes rejected, %zu of the %zu more than 3 m off\n",
                d.name.c_str(), s.rmse, s.max, s.rejected, s.fixes, s.far_rejected, s.far);
    EXPECT_LE(s.rmse, 1.1 * recorded[at].first) << d.name;
    EXPECT_LE(s.max, 1.1 * recorded[at].second) << d.name;
    EXPECT_GE(static_cast<double>(s.far_rejected), 0.9 * static_cast<double>(s.far)) << d.name;
  }
}

/// The pose sigmas of every drive with GNSS of `kind`: pooled, 85-99 % of the poses within
/// 2.45 sigma_h and 1.96 sigma_v, at least 75 % on every drive.
void expectSigmasCover(const std::vector<std::string>& dirs, const char* kind) {
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
  EXPECT_LE(pooled.shareH(), 0.99) << kind;
  EXPECT_GE(pooled.shareV(), 0.85) << kind;
  EXPECT_LE(pooled.shareV(), 0.99) << kind;
}

// With RTK GNSS: 90.7 % pooled horizontally, 75.6-100 % per drive. Where the clock is held at
// the speed profile, its sigma holds what a SLAM's own lag moves that profile by (KAIST_03:
// 12.6 -> 89.5 %).
TEST(MulranDrives, PoseSigmasCoverTheErrorsWithRtkGnss) {
  const std::vector<std::string> dirs = test::findTruthDrives("mulran_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "mulran_lo");
  expectSigmasCover(dirs, "rtk");
}

// With urban GNSS (1 Hz, no std-dev): 87.0 % pooled horizontally, 76.8-93.8 % per drive. The
// clock is held at the stamps as given on all but DCC_02 (true offsets 38-58 ms, within the
// speed profiles' noise), and the along-track error it leaves counts where the fixes hide it
// (DCC_03, KAIST_02, KAIST_03: 71.4, 78.0, 67.5 % without).
TEST(MulranDrives, PoseSigmasCoverTheErrorsWithUrbanGnss) {
  const std::vector<std::string> dirs = test::findTruthDrives("mulran_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "mulran_lo");
  expectSigmasCover(dirs, "urban");
}

}  // namespace
}  // namespace flexcloud
