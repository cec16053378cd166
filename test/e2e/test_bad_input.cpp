// Messy drives: each case ends in a correct result with what was skipped counted, or in one
// clear error. Never a crash, a hang, a NaN or a point lost.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <random>

#include "flexcloud/georeference.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/sim/sim_cloud.h"
#include "flexcloud/warp/cloud_warp.h"
#include "test_util.h"

namespace flexcloud {
namespace {

using test::atSimDatum;
using test::inputOf;
using test::mapError;

sim::SimParams small(std::uint64_t seed = 21) {
  sim::SimParams sp;
  sp.seed = seed;
  sp.map_points = 30000;
  return sp;
}

/// The published method's path: no fusion (the jump filter and GNSS control points).
Params legacy(Params p = {}) {
  p.fusion = false;
  return p;
}

/// How many of the fixes stamped in [t0, t1) seconds after the start the fusion rejected.
std::size_t rejectedBetween(const GeoreferenceResult& r, const sim::SimDrive& d, double t0,
                            double t1) {
  std::size_t n = 0;
  for (const auto& o : r.fusion->fixes) {
    const double t = o.stamp - d.params.start_stamp;
    if (t >= t0 && t < t1 && o.verdict != FixVerdict::kUsed) ++n;
  }
  return n;
}

std::string errorOf(const DriveInput& in, const Params& p) {
  return test::errorOf([&] { georeference(in, p); });
}

TEST(BadInput, GnssJumpOfHundredsOfMetresForTwentySeconds) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput in = inputOf(d);
  for (auto& f : in.fixes) {
    const double t = f.fix.stamp - d.params.start_stamp;
    if (t >= 100.0 && t < 120.0) f.fix.lat += 0.003;  // 333 m north
  }
  const GeoreferenceResult r = georeference(in, legacy(atSimDatum(d)));
  EXPECT_EQ(r.gnss.dropped.outlier, 100u);  // 20 s at 5 Hz, by the jump filter
  EXPECT_LE(mapError(d, r).rmse, 0.25);
  // The fusion rejects exactly those, and the map is as good.
  const GeoreferenceResult f = georeference(in, atSimDatum(d));
  EXPECT_EQ(rejectedBetween(f, d, 100.0, 120.0), 100u);
  EXPECT_LE(f.fusion->outliers, 105u);
  EXPECT_LE(mapError(d, f).rmse, 0.1);
}

TEST(BadInput, DuplicateAndOutOfOrderStampsGiveTheCleanResult) {
  const sim::SimDrive d = sim::simulateDrive(small());
  const GeoreferenceResult clean = georeference(inputOf(d), Params{});
  DriveInput messy = inputOf(d);
  std::mt19937 rng(1);
  std::shuffle(messy.poses.begin(), messy.poses.end(), rng);
  std::shuffle(messy.fixes.begin(), messy.fixes.end(), rng);
  for (int k = 0; k < 50; ++k) messy.poses.push_back(messy.poses[static_cast<std::size_t>(k)]);
  for (int k = 0; k < 30; ++k) messy.fixes.push_back(messy.fixes[static_cast<std::size_t>(k)]);
  const GeoreferenceResult r = georeference(messy, Params{});
  EXPECT_EQ(r.pose_counts.duplicate, 50u);
  EXPECT_GT(r.pose_counts.reordered, 1000u);
  EXPECT_EQ(r.gnss.dropped.duplicate, 30u);
  EXPECT_LT((r.T_enu_map.matrix() - clean.T_enu_map.matrix()).norm(), 1e-9);
  EXPECT_NEAR(r.metrics_rubbersheet.mae, clean.metrics_rubbersheet.mae, 1e-9);
  // What was dropped is said where users read, not in report.json alone.
  const std::vector<std::string> w = resultWarnings(r, Params{}, nullptr);
  ASSERT_FALSE(w.empty());
  EXPECT_EQ(w.front(), "input: 30 of " + std::to_string(messy.fixes.size()) +
                           " fixes dropped: 30 with the stamp of an earlier fix; 50 of " +
                           std::to_string(messy.poses.size()) +
                           " poses dropped: 50 with the stamp of an earlier pose (report.json: "
                           "counts)");
  for (const auto& c : resultWarnings(clean, Params{}, nullptr)) {
    EXPECT_NE(c.rfind("input: ", 0), 0u) << c;
  }
}

TEST(BadInput, BrokenQuaternionsAreCountedNotFatal) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput in = inputOf(d);
  for (std::size_t i = 0; i < in.poses.size(); i += 100) in.poses[i].orientation.coeffs() *= 3.0;
  for (std::size_t i = 50; i < in.poses.size(); i += 100) {
    in.poses[i].orientation.coeffs() << std::nan(""), 0, 0, 1;
  }
  in.poses[7].orientation.coeffs().setZero();
  // Fixes a receiver or a converter broke: a latitude beyond 90 deg, a negative std-dev.
  in.fixes[10].fix.lat = 95.0;
  for (std::size_t i = 20; i < 25; ++i) in.fixes[i].fix.std_enu.x() = -0.1;
  const GeoreferenceResult r = georeference(in, Params{});
  EXPECT_EQ(r.pose_counts.normalised, 42u);
  EXPECT_EQ(r.pose_counts.invalid, 43u);  // 42 NaN and one zero quaternion
  EXPECT_EQ(r.gnss.dropped.invalid, 6u);
  for (const auto& p : r.rubbersheet) EXPECT_NEAR(p.orientation.norm(), 1.0, 1e-9);
  const std::vector<std::string> w = resultWarnings(r, Params{}, nullptr);
  ASSERT_FALSE(w.empty());
  EXPECT_EQ(w.front().rfind("input: 6 of " + std::to_string(in.fixes.size()) +
                                " fixes dropped: 6 invalid (a stamp, coordinate or std-dev",
                            0),
            0u)
      << w.front();
  EXPECT_NE(w.front().find("; 43 of " + std::to_string(in.poses.size()) +
                           " poses dropped: 43 invalid (a stamp, position or quaternion"),
            std::string::npos)
      << w.front();
}

TEST(BadInput, NoTimeOverlapSaysSo) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput in = inputOf(d);
  for (auto& f : in.fixes) f.fix.stamp += 10000.0;
  const std::string e = errorOf(in, Params{});
  EXPECT_EQ(e.rfind("no time overlap: GNSS spans [", 0), 0u) << e;
  // The offset that starts the GNSS with the poses, in the convention of gnss_time_offset; given,
  // it makes the run.
  EXPECT_NE(e.find("; if the two clocks differ by a constant, gnss_time_offset -10000.000 (SLAM "
                   "clock minus GNSS clock, s) starts the GNSS with the poses"),
            std::string::npos)
      << e;
  Params given = atSimDatum(d);
  given.gnss_time_offset = -10000.0;
  EXPECT_LT(georeference(in, given).metrics_rubbersheet.mae, 0.05);
}

// Poses stamped in microseconds counted from 0, read as seconds, overlap the GNSS's seconds at
// their start: the error names the stamps' unit, not the std-dev threshold the few poses with
// GNSS failed on before.
TEST(BadInput, PosesInMicrosecondsFromZeroNameTheUnit) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput in = inputOf(d);
  const double t0 = d.params.start_stamp;
  for (auto& f : in.fixes) f.fix.stamp -= t0;
  for (auto& p : in.poses) p.stamp = (p.stamp - t0) * 1e6;
  const std::string e = errorOf(in, Params{});
  EXPECT_EQ(e.rfind("only ", 0), 0u) << e;
  EXPECT_NE(e.find("poses lie within the GNSS's time span"), std::string::npos) << e;
  EXPECT_NE(e.find("are the poses' stamps in us? (the tool's --poses-stamp-unit)"),
            std::string::npos)
      << e;
  EXPECT_EQ(e.find("stddev_threshold"), std::string::npos) << e;
}

// Fixes that all claim a kilometre place the result with that uncertainty: no pose is known
// within a hundred times max_sigma_h, and the result is degraded (refused unless
// accept_degraded), where it was a result like any other, its sigma 866 km. Fixes that claim a
// metre are ordinary GNSS: uncertain, not degraded.
TEST(BadInput, FixesThatAllClaimAKilometreAreADegradedResult) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput in = inputOf(d);
  for (auto& f : in.fixes) f.fix.std_enu = Eigen::Vector3d::Constant(1e6);
  Params p = atSimDatum(d);
  const GeoreferenceResult r = georeference(in, p);
  EXPECT_GT(r.sigma.median_h, 100.0);
  const std::string e = test::errorOf([&] { checkDegraded(r, p, nullptr, "map"); });
  EXPECT_EQ(e.rfind("the result cannot be right: no pose is known within 100 times max_sigma_h "
                    "(50.000 m): the least uncertain may lie 866025.404 m",
                    0),
            0u)
      << e;
  p.accept_degraded = true;
  EXPECT_NO_THROW(checkDegraded(r, p, nullptr, "map"));
  // Fixes of a metre: poses known within it, no such line.
  for (auto& f : in.fixes) f.fix.std_enu = Eigen::Vector3d(1.0, 1.0, 2.0);
  p.accept_degraded = false;
  EXPECT_NO_THROW(checkDegraded(georeference(in, p), p, nullptr, "map"));
}

TEST(BadInput, PartialOverlapWarpsEverythingAndCountsTheUnmatched) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput in = inputOf(d);
  const double t0 = d.params.start_stamp;
  in.fixes.erase(std::remove_if(in.fixes.begin(), in.fixes.end(),
                                [&](const RawFix& f) {
                                  return f.fix.stamp < t0 + 100.0 || f.fix.stamp > t0 + 300.0;
                                }),
                 in.fixes.end());
  const GeoreferenceResult r = georeference(in, atSimDatum(d));
  EXPECT_NEAR(static_cast<double>(r.poses_matched), 2001.0, 2.0);  // 200 s at 10 Hz
  EXPECT_EQ(r.rubbersheet.size(), d.slam.size());
  WarpStats s;
  const ErrorStats e = mapError(d, r, &s);
  EXPECT_EQ(s.outside, 0u);  // the cuboid encloses the whole trajectory, matched or not
  EXPECT_TRUE(std::isfinite(e.rmse));
}

/// A map in another frame than its poses (shifted 500 m, or turned 90 degrees about the start)
/// is warped, and the warning names the frame; the map in its own frame gets no such warning.
TEST(BadInput, AMapInAnotherFrameIsNamed) {
  const sim::SimDrive d = sim::simulateDrive(small());
  const GeoreferenceResult r = georeference(inputOf(d), atSimDatum(d));
  const auto warnings = [&](const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& move) {
    pcl::PCLPointCloud2 cloud = sim::slamCloud(d.map);
    const XyzLayout l = xyzLayout(cloud, "map");
    for (std::size_t i = 0; i < l.points; ++i) {
      std::uint8_t* p = cloud.data.data() + i * l.point_step;
      l.set(p, move(l.get(p)));
    }
    const WarpStats s = warpCloud(cloud, *r.sheet, 0);
    EXPECT_GT(s.sample.size(), 900u);
    std::printf("map points farther than 50 m from every pose: %.3f, poses in the map %.3f\n",
                shareFarFromPoses(r, s, 50.0), sharePosesInMap(r, s, 50.0));
    std::string frame_warning;
    for (const auto& w : resultWarnings(r, Params{}, &s, "slam_map")) {
      if (w.find("from every pose") != std::string::npos) frame_warning = w;
    }
    return frame_warning;
  };
  EXPECT_EQ(warnings([](const Eigen::Vector3d& p) -> Eigen::Vector3d { return p; }), "");
  const std::string shifted = warnings([](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    return p + Eigen::Vector3d(500.0, 0.0, 0.0);
  });
  EXPECT_NE(shifted.find("is the map in the frame of the poses, 'slam_map'?"), std::string::npos)
      << shifted;
  const std::string turned = warnings([](const Eigen::Vector3d& p) -> Eigen::Vector3d {
    return Eigen::Vector3d(-p.y(), p.x(), p.z());
  });
  EXPECT_NE(turned.find("'slam_map'"), std::string::npos) << turned;
}

/// The georeferencing asked for while the drive is not complete (a bag still playing): the
/// poses so far lie inside the map and cover part of it, and the warning says so, not that the
/// map is in another frame.
TEST(BadInput, APartOfTheDriveIsNamedAsSuch) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput in = inputOf(d);
  const double end =
      in.poses.front().stamp + 0.3 * (in.poses.back().stamp - in.poses.front().stamp);
  in.poses.erase(std::remove_if(in.poses.begin(), in.poses.end(),
                                [&](const Pose& p) { return p.stamp > end; }),
                 in.poses.end());
  const GeoreferenceResult r = georeference(in, atSimDatum(d));
  pcl::PCLPointCloud2 cloud = sim::slamCloud(d.map);
  const WarpStats s = warpCloud(cloud, *r.sheet, 0);
  const double far = shareFarFromPoses(r, s, 50.0);
  std::printf("a third of the drive: %.3f of the map far, %.3f of the poses in the map\n", far,
              sharePosesInMap(r, s, 50.0));
  ASSERT_GT(far, 0.5);
  std::string said;
  for (const auto& w : resultWarnings(r, Params{}, &s, "slam_map")) {
    if (w.find("of the map (within 50 m)") != std::string::npos) said = w;
    EXPECT_EQ(w.find("frame of the poses"), std::string::npos) << w;
  }
  EXPECT_EQ(said, "degraded: the poses cover " + std::to_string(std::lround(100.0 * (1.0 - far))) +
                      " % of the map (within 50 m): is the drive complete? (a bag still playing "
                      "has given part of its poses) The map beyond them has no control point "
                      "near it");
}

TEST(BadInput, PerfectlyFlatTrajectoryAndGnss) {
  sim::SimParams sp = small();
  sp.elevation = 0.0;
  sp.gnss_noise_v = 0.0;
  sp.pitch_bias = 0.0;
  sim::SimDrive d = sim::simulateDrive(sp);
  DriveInput in = inputOf(d);
  for (auto& p : in.poses) p.position.z() = 0.0;  // every z equal
  // The map's points keep their SLAM heights relative to the (now level) trajectory.
  for (std::size_t i = 0; i < d.map.slam.size(); ++i) d.map.slam[i].z() = d.map.slam[i].z();
  const GeoreferenceResult r = georeference(in, atSimDatum(d));
  EXPECT_EQ(r.control_points.points.size(), 200u);
  EXPECT_GT(r.sheet->numTetrahedra(), 200u);
  WarpStats s;
  mapError(d, r, &s);  // every point warped, none lost, none NaN
  EXPECT_EQ(s.outside, 0u);
  EXPECT_LT(r.metrics_rubbersheet.mae, 0.1);
  for (const auto& p : r.rubbersheet) EXPECT_TRUE(p.position.allFinite());
}

TEST(BadInput, FewerThanFourPosesIsAClearError) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput in = inputOf(d);
  in.poses.resize(3);
  for (const Params& p : {legacy(), Params{}}) {
    const std::string e = errorOf(in, p);
    EXPECT_EQ(e, "poses: 3 of the 3 poses usable, at least 4 are needed") << e;
  }
  DriveInput empty = inputOf(d);
  empty.poses.clear();
  EXPECT_EQ(errorOf(empty, Params{}), "poses: none given (an empty file, topic or bag)");
  // Poses that all share one stamp leave one: the error says so, not what follows from it.
  DriveInput same = inputOf(d);
  for (auto& p : same.poses) p.stamp = same.poses.front().stamp;
  const std::string e = errorOf(same, Params{});
  EXPECT_EQ(e, "poses: 1 of the " + std::to_string(same.poses.size()) + " poses usable (" +
                   std::to_string(same.poses.size() - 1) +
                   " with the stamp of an earlier pose), at least 4 are needed")
      << e;
}

// Two fixes 0.2 s apart put GNSS at three poses: the alignment has its three pairs, the sheet
// not its four control points.
TEST(BadInput, FewerThanFourControlPointsIsAClearError) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput in = inputOf(d);
  in.fixes.resize(2);
  const std::string e = errorOf(in, legacy());
  EXPECT_EQ(e.rfind("control points: 3 usable of 200 requested (3 poses with GNSS", 0), 0u) << e;
  EXPECT_NE(e.find("at least 4 are needed"), std::string::npos) << e;
}

TEST(BadInput, MoreControlPointsAskedThanPoses) {
  sim::SimParams sp = small();
  sp.length = 400.0;  // 334 poses
  const sim::SimDrive d = sim::simulateDrive(sp);
  Params p = atSimDatum(d);
  p.control_points = 10000;
  const GeoreferenceResult r = georeference(inputOf(d), p);
  EXPECT_LE(r.control_points.points.size(), d.slam.size());
  EXPECT_GT(r.control_points.points.size(), 100u);
  EXPECT_LT(r.metrics_rubbersheet.mae, 0.05);
  EXPECT_TRUE(std::isfinite(mapError(d, r).rmse));
}

/// Every fix reported at 5 m: the fusion (the default) weighs them by their std-dev and says
/// so; without it, the error names the threshold, the fixes' std-devs and a value that works.
TEST(BadInput, EveryFixAboveTheThresholdNamesTheThreshold) {
  sim::SimParams sp = small();
  sp.reported_std_h = sp.reported_std_v = 5.0;
  const sim::SimDrive d = sim::simulateDrive(sp);
  const GeoreferenceResult fused = georeference(inputOf(d), atSimDatum(d));
  EXPECT_EQ(fused.threshold_lifted,
            "stddev_threshold 0.100 m leaves 0 of " + std::to_string(d.fixes.size()) +
                " fixes (median horizontal std-dev 5.000 m): the fusion weighs every fix by its "
                "std-dev instead");
  const auto said = resultWarnings(fused, Params{}, nullptr, "map");
  EXPECT_NE(std::find(said.begin(), said.end(), fused.threshold_lifted), said.end());
  Params simple;
  simple.fusion = false;
  const std::string e = errorOf(inputOf(d), simple);
  EXPECT_NE(e.find(" poses with GNSS have a horizontal std-dev (the larger of east and north) "
                   "within stddev_threshold 0.100 m (their horizontal std-devs: 5th percentile "
                   "5.000 m, median 5.000 m, 95th percentile 6.250 m; stddev_threshold 6.3 keeps "
                   "95 % of them), at least 3 are needed"),
            std::string::npos)
      << e;
  // Between fixes the GNSS at a pose is less certain (up to 1.25x): the value the error gives.
  simple.stddev_threshold = 6.3;
  EXPECT_NO_THROW(georeference(inputOf(d), simple));
}

/// The GNSS of another drive beside this drive's poses: the result cannot be right, and the
/// reasons say why; this drive's own GNSS gives none.
TEST(BadInput, TheGnssOfAnotherDriveIsADegradedResult) {
  const sim::SimDrive d = sim::simulateDrive(small());
  sim::SimParams other = small(99);
  other.length *= 1.3;
  const sim::SimDrive e = sim::simulateDrive(other);
  DriveInput in = inputOf(d);
  in.fixes = e.fixes;
  const GeoreferenceResult r = georeference(in, atSimDatum(d));
  const std::vector<std::string> reasons = degradedReasons(r, nullptr, "map");
  ASSERT_FALSE(reasons.empty()) << "scale " << r.scale;
  EXPECT_THROW(checkDegraded(r, atSimDatum(d), nullptr, "map"), Error);
  Params accepted = atSimDatum(d);
  accepted.accept_degraded = true;
  EXPECT_NO_THROW(checkDegraded(r, accepted, nullptr, "map"));
  EXPECT_TRUE(degradedReasons(georeference(inputOf(d), atSimDatum(d)), nullptr, "map").empty());
}

/// The threshold is compared with the horizontal std-dev: fixes at 5 cm horizontally and 20 cm
/// vertically (3D 21 cm) pass a threshold of 10 cm.
TEST(BadInput, TheThresholdIsHorizontal) {
  sim::SimParams sp = small();
  sp.reported_std_h = 0.05;
  sp.reported_std_v = 0.2;
  const sim::SimDrive d = sim::simulateDrive(sp);
  Params simple;
  simple.fusion = false;
  const GeoreferenceResult r = georeference(inputOf(d), simple);
  EXPECT_EQ(r.control_points.points.size(), 200u);
  EXPECT_TRUE(r.threshold_lifted.empty());
}

TEST(BadInput, NoFixAtAll) {
  const sim::SimDrive d = sim::simulateDrive(small());
  DriveInput none = inputOf(d);
  none.fixes.clear();
  EXPECT_EQ(errorOf(none, Params{}), "GNSS: no fix given (an empty file, topic or bag)");
  DriveInput lost = inputOf(d);
  for (auto& f : lost.fixes) f.has_fix = false;
  const std::string n = std::to_string(lost.fixes.size());
  EXPECT_EQ(errorOf(lost, Params{}), "GNSS: none of the " + n + " fixes is usable (no fix " + n +
                                         ", invalid 0, unknown covariance 0, duplicate 0, jump 0)");
}

TEST(BadInput, LapsRevisitTheSamePlace) {
  sim::SimParams sp = small();
  sp.laps = 3;
  sp.length = 2000.0;
  const sim::SimDrive d = sim::simulateDrive(sp);
  const GeoreferenceResult r = georeference(inputOf(d), atSimDatum(d));
  const ErrorStats e = mapError(d, r);
  std::printf(
      "3 loop-closed laps: map RMSE %.3f m, MAX %.3f m; %zu revisit pairs, %zu conflicting\n",
      e.rmse, e.max, r.revisits.pairs, r.revisits.conflicting);
  EXPECT_LE(e.rmse, 0.25);
  EXPECT_LT(r.metrics_rubbersheet.max, 0.3);
  EXPECT_GT(r.revisits.pairs, 50u);  // the laps do revisit (111 with g++, 99 with clang)
  EXPECT_EQ(r.revisits.conflicting, 0u);
}

TEST(BadInput, LapsTheSlamNeverClosedAreFlagged) {
  // Without loop closure between laps the map holds every wall once per lap, metres apart, each
  // needing another correction: one warp of space cannot serve them all. The result stays
  // finite, every point is kept, and the conflict is reported so the user closes the loops.
  sim::SimParams sp = small();
  sp.laps = 3;
  sp.length = 2000.0;
  sp.close_each_lap = false;
  const sim::SimDrive d = sim::simulateDrive(sp);
  const GeoreferenceResult r = georeference(inputOf(d), atSimDatum(d));
  pcl::PCLPointCloud2 map = sim::slamCloud(d.map);
  const ErrorStats rigid =
      compareClouds(map, sim::truthCloud(d.map),
                    [&](const Eigen::Vector3d& x) { return Eigen::Vector3d(r.T_enu_map * x); });
  const ErrorStats e = mapError(d, r);
  std::printf(
      "3 unclosed laps: map RMSE %.3f m (rigid only %.3f m); %zu of %zu revisit pairs "
      "conflict, by up to %.2f m\n",
      e.rmse, rigid.rmse, r.revisits.conflicting, r.revisits.pairs, r.revisits.worst);
  EXPECT_TRUE(std::isfinite(e.rmse));
  EXPECT_GT(r.revisits.conflicting, 20u);
  EXPECT_GT(r.revisits.worst, 1.0);
}

TEST(BadInput, ALongOutageWithHighStdDev) {
  sim::SimParams sp = small();
  sp.outages = {{50.0, 170.0}};  // two minutes, 1.4 km of path
  const sim::SimDrive d = sim::simulateDrive(sp);
  const GeoreferenceResult r = georeference(inputOf(d), legacy(atSimDatum(d)));
  for (const auto& cp : r.control_points.points) {
    const double t = cp.stamp - sp.start_stamp;
    EXPECT_FALSE(t > 50.5 && t < 169.5);
  }
  EXPECT_GT(r.control_points.skipped, 0u);
  EXPECT_TRUE(std::isfinite(mapError(d, r).rmse));
  // The fusion leaves the outage's fixes out (their std-dev is above the threshold) and carries
  // the trajectory across on the SLAM: control points inside the outage hold that estimate.
  const GeoreferenceResult f = georeference(inputOf(d), atSimDatum(d));
  EXPECT_EQ(f.fusion->above_threshold, 601u);  // 120 s at 5 Hz, both ends
  const ErrorStats fused = mapError(d, f);
  std::printf("2 min outage: map RMSE %.3f m with the fusion, %.3f m without\n", fused.rmse,
              mapError(d, r).rmse);
  EXPECT_LE(fused.rmse, 0.5);
}

}  // namespace
}  // namespace flexcloud
