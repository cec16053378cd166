// Real LiDAR odometry against the truth (../shared/data/kitti_lo: nine KITTI drives, SiMpLE
// odometry without loop closure, the GNSS simulated from the truth): the defaults follow honest
// RTK GNSS at least as closely as `fusion: false`, bridge urban GNSS's multipath and outliers,
// find a known clock offset, and keep the drive's ends as good as its middle. Each test skips
// with a message where the data is absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "flexcloud/fusion/clock_offset.h"
#include "flexcloud/georeference.h"
#include "real_drive.h"
#include "truth_drives.h"

namespace flexcloud {
namespace {

const std::vector<std::string> kDrives = {"01", "02", "03", "04", "05", "06", "07", "09", "10"};

/// visit(drive, kind) for every drive in `dirs` and GNSS kind ("rtk", "urban") it has.
template <typename Visit>
void forEachKind(const std::vector<std::string>& dirs, Visit&& visit) {
  for (const auto& dir : dirs) {
    for (const std::string kind : {"rtk", "urban"}) {
      if (std::filesystem::exists(dir + "/gnss_" + kind + ".txt")) {
        visit(study::loadTruthDrive(dir, kind), kind);
      }
    }
  }
}

// Honest RTK GNSS (2 cm, std-devs exactly right): the defaults' horizontal RMSE and MAX at most
// fusion: false's plus 10 % plus 1 cm and below the published method's, every fix kept but at
// most 1 %, the first and last 20 s no worse than the rest give or take 2 cm of the fixes' own
// noise (01, a motorway drive of 110 s: 0.069 m 7 s before its end, where the fused trajectory
// is 0.068 m off, against 0.053 m elsewhere; 04, a 27 s drive, has no middle), and no clock
// offset applied.
TEST(TruthDrives, HonestRtkGnssIsFollowedAtLeastAsCloselyAsBySheetAlone) {
  const std::vector<std::string> dirs = test::findTruthDrives("kitti_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "kitti_lo");
  for (const auto& dir : dirs) {
    const study::TruthDrive d = study::loadTruthDrive(dir, "rtk");
    const GeoreferenceResult r = georeference(d.input, Params{});
    const GeoreferenceResult g = georeference(d.input, study::simpleWay());
    const study::TruthScore s = study::scoreAgainstTruth(d, r);
    const study::TruthScore f = study::scoreAgainstTruth(d, g);
    const study::TruthScore pub =
        study::scoreAgainstTruth(d, georeference(d.input, study::publishedMethod()));
    std::printf(
        "%s: defaults %.3f / %.3f m (ends %.3f, elsewhere %.3f), fusion: false %.3f / %.3f m; "
        "%zu of %zu fixes rejected, %zu taken back, clock %+.1f ms\n",
        d.name.c_str(), s.rmse, s.max, s.ends_max, s.middle_max, f.rmse, f.max, s.rejected, s.fixes,
        r.fusion->follow.taken_back, 1e3 * r.clock_offset);
    EXPECT_LE(s.rmse, 1.1 * f.rmse + 0.01) << d.name;
    EXPECT_LE(s.max, 1.1 * f.max + 0.01) << d.name;
    // Closer than the published method on every drive (03: 0.015 / 0.046 against 0.035 / 0.126
    // m; with its SLAM's lag taken for a clock, 0.129 / 0.229).
    EXPECT_LT(s.rmse, pub.rmse) << d.name;
    EXPECT_LT(s.max, pub.max) << d.name;
    EXPECT_LE(s.rejected, s.fixes / 100) << d.name;
    if (d.name != "04 rtk") {
      EXPECT_LE(s.ends_max, s.middle_max + 0.02) << d.name;
    }
    // Their true offset is 0: a SLAM's own lag (03: 17-28 ms) is not taken for a clock.
    EXPECT_EQ(r.clock_offset, 0.0) << d.name;
    EXPECT_EQ(g.clock_offset, 0.0) << d.name;
    if (d.name == "03 rtk") {  // its profiles show 23 ms: said, as what a SLAM's lag can show
      bool said = false;
      for (const auto& w : resultWarnings(r, Params{}, nullptr)) {
        said = said || (w.rfind("clock: ", 0) == 0 &&
                        w.find("no more than a SLAM's own lag") != std::string::npos);
      }
      EXPECT_TRUE(said);
    }
  }
}

// KITTI's LiDAR odometry puts every pose 1.1-2.0 cm off a smooth path, each by an error of its
// own (its truth: 0.1-0.2 cm), which every smooth correction carries into the result: measured
// and taken out by a local cubic over 0.8-1 s, the defaults come closer to the truth on every
// RTK drive, by a third together (01: 0.024 -> 0.016 m RMSE; 02, where the sheet's folds lead,
// 0.057 -> 0.048 m; 04: 0.085 -> 0.028 m MAX), and no urban drive moves away from it.
TEST(TruthDrives, TheSlamsJitterIsTakenOutOfTheTrajectories) {
  const std::vector<std::string> dirs = test::findTruthDrives("kitti_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "kitti_lo");
  Params raw;
  raw.smooth_jitter = false;
  double smoothed = 0.0, unsmoothed = 0.0;  // the RTK drives' RMSE, summed
  forEachKind(dirs, [&](const study::TruthDrive& d, const std::string& kind) {
    const GeoreferenceResult r = georeference(d.input, Params{});
    const study::TruthScore s = study::scoreAgainstTruth(d, r);
    const study::TruthScore u = study::scoreAgainstTruth(d, georeference(d.input, raw));
    std::printf(
        "%s: jitter %.4f m (own %.2f), %d poses either side: %.3f / %.3f m, "
        "unsmoothed %.3f / %.3f m\n",
        d.name.c_str(), r.jitter.white, r.jitter.own_share, r.jitter.half_width, s.rmse, s.max,
        u.rmse, u.max);
    EXPECT_TRUE(r.jitter.seen) << d.name;
    EXPECT_GT(r.jitter.white, 0.010) << d.name;
    EXPECT_LT(r.jitter.white, 0.021) << d.name;
    EXPECT_GE(r.jitter.half_width, 4) << d.name;
    if (kind == "rtk") {
      EXPECT_LT(s.rmse, 0.9 * u.rmse) << d.name;
      EXPECT_LT(s.max, u.max) << d.name;
      smoothed += s.rmse, unsmoothed += u.rmse;
    } else {
      EXPECT_LE(s.rmse, u.rmse) << d.name;
    }
  });
  EXPECT_LT(smoothed, 0.72 * unsmoothed);  // 0.175 against 0.261 m
}

// Urban GNSS at 1 Hz (0.3 m white noise, multipath of 1-8 m over 5-60 s, 2 % outliers of 3-30 m,
// no std-devs): the defaults bridge it. Every fix more than 3 m off the truth is rejected; the
// horizontal RMSE stays within 0.40 m and the MAX within 1.5 m, but the RMSE of drive 02, whose
// SLAM bridges its 25 s multipath episodes with up to 1.4 m of its own drift (0.407 / 1.40 m).
TEST(TruthDrives, UrbanGnssIsBridged) {
  const std::vector<std::string> dirs = test::findTruthDrives("kitti_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "kitti_lo");
  for (const auto& dir : dirs) {
    if (!std::filesystem::exists(dir + "/gnss_urban.txt")) continue;  // 04 has none
    const study::TruthDrive d = study::loadTruthDrive(dir, "urban");
    const GeoreferenceResult r = georeference(d.input, Params{});
    const study::TruthScore s = study::scoreAgainstTruth(d, r);
    std::printf("%s\n", study::describeScore(d.name, s).c_str());
    const bool worst = d.name == "02 urban";
    EXPECT_LE(s.rmse, worst ? 0.42 : 0.40) << d.name;
    EXPECT_LE(s.max, 1.5) << d.name;
    EXPECT_EQ(s.far_rejected, s.far) << d.name;
    EXPECT_GT(s.far, 0u) << d.name;
  }
}

// Where the SLAM's height drifts away from code-grade fixes that are right (KITTI 02 with urban
// GNSS: its height 1.4-2.6 m below them for 15 s), those that agree with the fused trajectory
// horizontally take part with their horizontal part alone, and a warning says how many and
// where. Against the truth, at least 90 % of them lie within 1 m of it horizontally.
TEST(TruthDrives, FixesApartInHeightAloneTakePartHorizontally) {
  const std::vector<std::string> dirs = test::findTruthDrives("kitti_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "kitti_lo");
  std::size_t counted = 0, good = 0;
  for (const auto& dir : dirs) {
    if (!std::filesystem::exists(dir + "/gnss_urban.txt")) continue;
    const study::TruthDrive d = study::loadTruthDrive(dir, "urban");
    const GeoreferenceResult r = georeference(d.input, Params{});
    bool named = false;
    for (const auto& w : resultWarnings(r, Params{}, nullptr)) {
      named =
          named || w.find(" fixes took part with their horizontal part alone") != std::string::npos;
    }
    std::size_t k = 0, here = 0;
    for (const FixOutcome& o : r.fusion->fixes) {
      if (!o.height_left_out) continue;
      EXPECT_EQ(o.verdict, FixVerdict::kUsed);
      while (k + 1 < d.truth.size() && d.truth[k + 1].stamp <= o.stamp + 1e-6) ++k;
      ++here;
      good += (o.position - d.truth[k].position).head<2>().norm() < 1.0 ? 1 : 0;
    }
    counted += here;
    std::printf("%s: %zu fixes without their height (%zu in report.json), warned: %s\n",
                d.name.c_str(), here, r.fusion->heights_left_out, named ? "yes" : "no");
    EXPECT_EQ(here, r.fusion->heights_left_out) << d.name;
    EXPECT_EQ(named, here >= 3) << d.name;
    if (d.name == "02 urban") {
      EXPECT_GE(here, 10u);
    }
  }
  std::printf("%zu fixes without their height, %zu of them within 1 m of the truth\n", counted,
              good);
  EXPECT_GE(static_cast<double>(good), 0.9 * static_cast<double>(counted));
}

// The poses' stamps shifted by a known 0.1 or 0.3 s either way: on the RTK drives the offset is
// found to 5 ms but on 02 (5.0 ms at +0.1 s), 03 (the SLAM itself lags its truth there by 17-28
// ms in speed, heading and position alike: 17 ms, within twice the 1-sigma reported but at -0.1
// s, 2.06 times), 04 (a 27 s straight at steady speed) and 10 (its speed and heading profiles
// part by 20 ms); on every drive, RTK or urban, it is estimated and lies within twice the
// 1-sigma reported, but on the straight (04) at 0.1 s, where a warning says why not. With urban
// GNSS at 1 Hz the profiles know 0.1 s loosely (01: 0.12 +- 0.09 s) and the fit of positions
// decides it: the result keeps the bounds of the drives as given (held at 0, 01 was 2.4 m RMSE,
// 02 1.1 m).
TEST(TruthDrives, AKnownClockOffsetIsFoundOrHonestlyNot) {
  const std::vector<std::string> dirs = test::findTruthDrives("kitti_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "kitti_lo");
  sim::SigmaCoverage rtk;  // the RTK drives' pose sigmas with the offset estimated
  for (const auto& dir : dirs) {
    const std::string seq = std::filesystem::path(dir).filename().string();
    for (const std::string kind : {"rtk", "urban"}) {
      if (!std::filesystem::exists(dir + "/gnss_" + kind + ".txt")) continue;
      for (const double shift : {-0.3, -0.1, 0.1, 0.3}) {
        const study::TruthDrive d = study::loadTruthDrive(dir, kind, shift);
        const GeoreferenceResult r = georeference(d.input, Params{});
        const FusionResult& f = *r.fusion;
        const double error = r.clock_offset - shift;
        if (kind == "rtk" && f.time_offset_estimated) rtk += study::sigmaCoverage(d, r);
        std::printf("%s, stamps %+.1f s: offset %s, off by %+.1f ms (1-sigma %.1f ms)\n",
                    d.name.c_str(), shift, f.time_offset_estimated ? "estimated" : "not told",
                    1e3 * error, 1e3 * f.time_offset_sigma);
        std::string clock_warning;
        for (const auto& w : resultWarnings(r, Params{}, nullptr)) {
          if (w.rfind("clock: ", 0) == 0) clock_warning = w;
        }
        if (!f.time_offset_estimated) {
          EXPECT_TRUE(seq == "04" && std::abs(shift) < 0.2) << d.name << " " << shift;
          EXPECT_NE(clock_warning.find("the drive turns too little"), std::string::npos)
              << clock_warning;
          continue;
        }
        const bool lags = kind == "rtk" && seq == "03";  // the SLAM's own 17 ms
        EXPECT_LE(std::abs(error), lags ? 0.018 : 2.0 * f.time_offset_sigma)
            << d.name << " " << shift;
        // Told loosely: a warning says how loosely.
        if (f.time_offset_sigma > 0.05) {
          EXPECT_FALSE(clock_warning.empty()) << d.name;
        }
        if (kind == "rtk" && seq != "02" && seq != "03" && seq != "04" && seq != "10") {
          EXPECT_LE(std::abs(error), 0.005) << d.name << " " << shift;
        }
        if (kind == "urban") {
          const study::TruthScore s = study::scoreAgainstTruth(d, r);
          EXPECT_LE(s.rmse, seq == "02" ? 0.42 : 0.40) << d.name << " " << shift;
          EXPECT_LE(s.max, 1.5) << d.name << " " << shift;
        }
      }
    }
  }
  // The clock's sigma in the poses' sigmas: the speed times the offset's sigma, widened by half
  // the distance of the applied offset from the speed profile's. Pooled over the RTK drives
  // and shifts, 93.8 % within 2.45 sigma (the tightest profile's sigma alone: 86.1 %).
  std::printf("RTK drives, their offset estimated: %.1f / %.1f %% within 2.45 / 1.96 sigma\n",
              100.0 * rtk.shareH(), 100.0 * rtk.shareV());
  EXPECT_GE(rtk.shareH(), 0.90);
  EXPECT_GE(rtk.shareV(), 0.90);
}

// The pose sigmas against the truth: the share of poses within the 95 % circle (2.45 sigma)
// and the vertical 95 % (1.96 sigma), and the median sigma at most twice the RMSE. RTK: 85-99 %
// both ways on all nine. Urban: at least 85 % both ways, and within the band calibrated sigmas
// show on as many independent samples in 99 % of drives (12-61 on these drives, whose errors
// stay alike over 5-10 s: 79-100 % on the shortest, so a drive at 100 % says little alone).
// Pooled, where the samples are many: urban within that band (91-99 %), RTK within 93-98 %
// (94.3 / 96.7 %: vertically more cautious than the 94-96 % of a calibrated sigma).
TEST(TruthDrives, PoseSigmasCoverTheErrorsAgainstTheTruth) {
  const std::vector<std::string> dirs = test::findTruthDrives("kitti_lo", kDrives);
  SKIP_WITHOUT_DRIVES(dirs, "kitti_lo");
  std::vector<study::CalibrationRow> rows;
  sim::SigmaCoverage pooled[2];  // RTK, urban
  forEachKind(dirs, [&](const study::TruthDrive& d, const std::string& kind) {
    const GeoreferenceResult r = georeference(d.input, Params{});
    const study::TruthScore s = study::scoreAgainstTruth(d, r);
    const sim::SigmaCoverage c = study::sigmaCoverage(d, r);
    rows.push_back({d.name, c, r.sigma.median_h, s.rmse});
    const bool rtk = kind == std::string("rtk");
    pooled[rtk ? 0 : 1] += c;
    EXPECT_GE(c.shareH(), 0.85) << d.name;
    EXPECT_GE(c.shareV(), 0.85) << d.name;
    if (rtk) {
      EXPECT_LE(c.shareH(), 0.99) << d.name;
      EXPECT_LE(c.shareV(), 0.99) << d.name;
    } else {
      EXPECT_GE(c.shareH(), sim::calibratedBand(c.independent_h).low) << d.name;
      EXPECT_GE(c.shareV(), sim::calibratedBand(c.independent_v).low) << d.name;
    }
    EXPECT_LE(r.sigma.median_h, 2.0 * s.rmse) << d.name;
    EXPECT_GT(r.sigma.median_h, 0.0) << d.name;
  });
  study::printCalibrationRows(rows);
  const sim::CoverageBand urban_h = sim::calibratedBand(pooled[1].independent_h),
                          urban_v = sim::calibratedBand(pooled[1].independent_v);
  EXPECT_GE(pooled[1].independent_h, 100.0);
  EXPECT_GE(pooled[1].shareH(), urban_h.low);
  EXPECT_LE(pooled[1].shareH(), urban_h.high);
  EXPECT_GE(pooled[1].shareV(), urban_v.low);
  EXPECT_LE(pooled[1].shareV(), urban_v.high);
  EXPECT_GE(pooled[0].shareH(), 0.93);
  EXPECT_LE(pooled[0].shareH(), 0.98);
  EXPECT_GE(pooled[0].shareV(), 0.93);
  EXPECT_LE(pooled[0].shareV(), 0.98);
}

// KITTI 02 drives its streets twice, and its SLAM puts the passes metres apart: the points
// beside one pass lay near the other, and with 50 to 175 control points the sheet folded there,
// carrying poses up to 7.0 m (RTK GNSS) and 4.2 m (urban) off the fused trajectory, which the
// rounds that add control points had mended a round before their last. At any count asked for,
// the sheet keeps every pose within a metre of its fused pose (it folds no further: 0.57 m at
// 50 control points with urban GNSS is its resolution there), and the result within 0.5 m
// (RTK) and 1.6 m (urban) of the truth.
TEST(TruthDrives, TheSheetDoesNotFoldAtAnyControlPointCount) {
  const std::string dir = test::findTruthDrive("kitti_lo/02");
  if (dir.empty()) GTEST_SKIP() << "kitti_lo/02 not found; skipped";
  for (const std::string kind : {"rtk", "urban"}) {
    const study::TruthDrive d = study::loadTruthDrive(dir, kind);
    for (const int count : {50, 100, 150}) {
      Params p;
      p.control_points = count;
      const GeoreferenceResult r = georeference(d.input, p);
      ASSERT_TRUE(r.fusion.has_value());
      double off = 0.0;
      for (std::size_t i = 0; i < r.rubbersheet.size(); ++i) {
        off = std::max(off, (r.rubbersheet[i].position - r.fusion->poses[i].position).norm());
      }
      const study::TruthScore s = study::scoreAgainstTruth(d, r);
      std::printf(
          "%s, %d control points: the sheet at most %.3f m off the fused trajectory; "
          "RMSE %.3f MAX %.3f m against the truth\n",
          d.name.c_str(), count, off, s.rmse, s.max);
      EXPECT_LE(off, 1.0) << d.name << " " << count;
      EXPECT_LE(s.max, kind == "rtk" ? 0.5 : 1.6) << d.name << " " << count;
    }
  }
}

}  // namespace
}  // namespace flexcloud
