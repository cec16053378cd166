// The command-line tools, run as a user runs them: simulate_drive, then georeference on the bag
// and on text files, with good and bad input.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <sys/wait.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>

#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/warp/cloud_warp.h"
#include "test_util.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

using Result = test::ShellResult;
using test::sh;

std::string bin(const std::string& name) { return std::string(FLEXCLOUD_BIN_DIR) + "/" + name; }

nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

class Tools : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("flexcloud_tools_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    const Result r = sh(bin("simulate_drive") + " --out " + sim() + " --map-points 50000 --seed 4");
    ASSERT_EQ(r.code, 0) << r.output;
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string sim() { return (dir_ / "sim").string(); }
  static std::string out(const std::string& name) { return (dir_ / name).string(); }
  static std::string datum() { return " --datum 48.2620 11.6670 480.0"; }  // the simulator's
  /// The georeferenced map in the output folder `o` against `truth` (same points, same order).
  static ErrorStats againstTruth(const std::string& o, const pcl::PCLPointCloud2& truth) {
    return compareClouds(readPcd(o + "/map_georeferenced.pcd"), truth,
                         [](const Eigen::Vector3d& p) { return p; });
  }
  /// A map rebuilt from its points' poses against the sheet's map of the same points, both
  /// against their truth: all `points` there, closer in RMSE by a twentieth, and no further at
  /// the worst point (that is the fused pose's).
  static void expectCloserThanTheSheet(const char* what, const ErrorStats& rebuilt,
                                       const ErrorStats& warped, std::size_t points) {
    std::printf("%s rebuilt: RMSE %.4f MAX %.4f m; the sheet: RMSE %.4f MAX %.4f m\n", what,
                rebuilt.rmse, rebuilt.max, warped.rmse, warped.max);
    EXPECT_EQ(rebuilt.count, points) << what;
    EXPECT_LT(rebuilt.rmse, 0.95 * warped.rmse) << what;
    EXPECT_LE(rebuilt.max, warped.max) << what;
  }
  /// A drive of its own into `drive`, simulate_drive's options `args`; whether it was written.
  static bool simulate(const std::string& drive, const std::string& args) {
    return sh(bin("simulate_drive") + " --out " + drive + " " + args).code == 0;
  }
  /// Runs the tool on the simulated drive with `map` into out(name); returns the largest
  /// distance between its warped points and those of the same run on the binary map.
  static double warpedAgainstBinary(const std::string& map, const std::string& name) {
    const std::string args = " -q --bag " + sim() + "/drive.bag" + datum();
    const Result a = sh(bin("georeference") + args + " --map " + map + " --out " + out(name));
    EXPECT_EQ(a.code, 0) << a.output;
    const std::string binary = out("from_binary");
    if (!fs::exists(binary + "/map_georeferenced.pcd")) {
      const Result b =
          sh(bin("georeference") + args + " --map " + sim() + "/map.pcd --out " + binary);
      EXPECT_EQ(b.code, 0) << b.output;
    }
    const pcl::PCLPointCloud2 x = readPcd(out(name) + "/map_georeferenced.pcd");
    const pcl::PCLPointCloud2 y = readPcd(binary + "/map_georeferenced.pcd");
    const XyzLayout lx = xyzLayout(x, name), ly = xyzLayout(y, "binary");
    // (the same points; PCL's writers leave the padding bytes out, so the layouts differ)
    EXPECT_EQ(lx.points, ly.points);
    double worst = 0.0;
    for (std::size_t i = 0; i < std::min(lx.points, ly.points); ++i) {
      const Eigen::Vector3d d =
          lx.get(x.data.data() + i * lx.point_step) - ly.get(y.data.data() + i * ly.point_step);
      worst = std::max(worst, d.allFinite() ? d.norm() : 1e9);
    }
    return worst;
  }
  static fs::path dir_;
};
fs::path Tools::dir_;

/// Rows of numbers of a text file, '#' lines skipped.
std::vector<std::vector<double>> readRows(const std::string& path) {
  std::vector<std::vector<double>> rows;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    rows.emplace_back(std::istream_iterator<double>(ss), std::istream_iterator<double>());
  }
  return rows;
}

/// trajectory_sigma.txt pairs with trajectory_rubbersheet.txt, the summary leads with it, and
/// at least 85 % of the poses lie within 2.45 sigma of the simulator's truth (100 % here).
void expectSigmasCoverTheTruth(const std::string& sim, const std::string& o,
                               const std::string& output, const nlohmann::json& j) {
  const auto sig = readRows(o + "/trajectory_sigma.txt");
  const auto traj = readRows(o + "/trajectory_rubbersheet.txt");
  const auto truth = readRows(sim + "/truth_trajectory.txt");
  ASSERT_EQ(sig.size(), traj.size());
  ASSERT_EQ(truth.size(), traj.size());
  std::size_t within = 0;
  for (std::size_t i = 0; i < traj.size(); ++i) {
    ASSERT_EQ(sig[i].size(), 3u);
    EXPECT_NEAR(sig[i][0], traj[i][0], 1e-6);
    EXPECT_NEAR(truth[i][0], traj[i][0], 1e-6);
    within += std::hypot(traj[i][1] - truth[i][1], traj[i][2] - truth[i][2]) <= 2.45 * sig[i][1];
  }
  EXPECT_GE(static_cast<double>(within) / static_cast<double>(traj.size()), 0.85);
  const auto& u = j["uncertainty"];
  EXPECT_GT(u["sigma_h_median_m"].get<double>(), 0.0);
  EXPECT_GE(u["sigma_h_p95_m"].get<double>(), u["sigma_h_median_m"].get<double>());
  EXPECT_GE(u["worst_stretch"]["sigma_h_m"].get<double>(), u["sigma_h_p95_m"].get<double>());
  EXPECT_LT(u["worst_stretch"]["from"].get<double>(), u["worst_stretch"]["to"].get<double>());
  const auto lead = output.find("trajectory vs truth  sigma per axis: median ");
  ASSERT_NE(lead, std::string::npos) << output;
  EXPECT_LT(lead, output.find("fit to the GNSS     aligned: MAE"));
  // Beside it, the map's: its points' sigma by band of distance from the route, growing with it
  // (4 mrad of heading: 0.15 m more at 37.5 m), the rebuilt map's no larger than the sheet's.
  const auto map_line = output.find("map vs truth   sigma per axis, median (95th percentile)");
  ASSERT_NE(map_line, std::string::npos) << output;
  EXPECT_GT(map_line, lead);
  EXPECT_LT(map_line, output.find("fit to the GNSS     aligned: MAE"));
  const auto& bands = u["map"]["bands"];
  ASSERT_EQ(bands.size(), 3U);
  EXPECT_EQ(u["map"]["moved_by"], "rubber_sheet");
  for (std::size_t b = 0; b < 3; ++b) {
    const double median = bands[b]["sigma_h_median_m"].get<double>();
    EXPECT_GE(median, b == 0 ? 0.0 : bands[b - 1]["sigma_h_median_m"].get<double>() + 0.02);
    EXPECT_GE(bands[b]["sigma_h_p95_m"].get<double>(), median);
    EXPECT_LE(u["map"]["bands_if_rebuilt"][b]["sigma_h_median_m"].get<double>(), median + 1e-9);
  }
  EXPECT_GT(bands[2]["sigma_h_median_m"].get<double>(), 0.15);
  EXPECT_LT(bands[0]["sigma_h_median_m"].get<double>(), 0.1);
}

/// A SLAM whose poses jitter by 1.5 cm each (simulate_drive --pose-jitter): the summary says it
/// was smoothed and how much, report.json gives it, and the trajectory lies closer to the truth
/// than with smooth_jitter false. Without jitter (the fixture's drive), the summary says nothing.
TEST_F(Tools, TheSummarySaysTheSlamsJitterWasSmoothed) {
  const std::string drive = out("jittery");
  ASSERT_TRUE(simulate(drive, "--map-points 1000 --seed 4 --pose-jitter 0.015"));
  const auto rmse = [&](const std::string& o) {
    const auto traj = readRows(o + "/trajectory_rubbersheet.txt");
    const auto truth = readRows(drive + "/truth_trajectory.txt");
    double sum = 0.0;
    for (std::size_t i = 0; i < traj.size(); ++i) {
      sum += std::pow(traj[i][1] - truth[i][1], 2) + std::pow(traj[i][2] - truth[i][2], 2);
    }
    return std::sqrt(sum / static_cast<double>(traj.size()));
  };
  const std::string args = " --bag " + drive + "/drive.bag" + datum() + " --set report_png=false";
  const Result r = sh(bin("georeference") + args + " --out " + out("jittery_out"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("fixes rejected, SLAM jitter 1.5 cm smoothed, clock offset"),
            std::string::npos)
      << r.output;
  const nlohmann::json j = readJson(out("jittery_out") + "/report.json")["slam_jitter"];
  EXPECT_TRUE(j["smoothed"].get<bool>());
  EXPECT_NEAR(j["white_m"].get<double>(), 0.015, 0.0015);
  const Result raw =
      sh(bin("georeference") + args + " --set smooth_jitter=false --out " + out("jittery_raw"));
  ASSERT_EQ(raw.code, 0) << raw.output;
  EXPECT_EQ(raw.output.find("cm smoothed"), std::string::npos) << raw.output;
  EXPECT_LT(rmse(out("jittery_out")), 0.7 * rmse(out("jittery_raw")));
  const Result smooth = sh(bin("georeference") + " -q --bag " + sim() + "/drive.bag" + datum() +
                           " --set report_png=false --out " + out("smooth_out"));
  ASSERT_EQ(smooth.code, 0) << smooth.output;
  EXPECT_EQ(smooth.output.find("cm smoothed"), std::string::npos) << smooth.output;
}

/// A map whose points carry their scan's time (simulate_drive --map-time), of a loop the SLAM
/// never closed (its last stretch 20 m beside its first in the SLAM's map): each point is moved
/// with its own pose, and the map lies closer to its truth than the rubber sheet's
/// (map_pose_field none) in RMSE and no further at its worst point (0.023 / 0.085 m against
/// 0.865 / 16.0 m: one warp cannot serve both passes). On three laps whose passes lie close, the
/// sheet with its second ring of points beside came within 1 % of it built with clang's
/// sanitizers. The summary and report.json say how it was moved. A field named that cannot name
/// poses fails the run naming it.
TEST_F(Tools, AMapWhosePointsKnowTheirTimeIsRebuiltFromTheirPoses) {
  const std::string drive = out("timed");
  ASSERT_TRUE(simulate(drive, "--scenario loop_unclosed --map-points 100000 --seed 5 --map-time"));
  const std::string run = bin("georeference") + " --bag " + drive + "/drive.bag --map " + drive +
                          "/map.pcd --truth " + drive + "/truth_map.pcd" + datum() +
                          " --set report_png=false";
  const Result r = sh(run + " --out " + out("timed_out"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("100000 points rebuilt, each with its own pose (field 'time'; 0 naming "
                          "none, 0 NaN kept)"),
            std::string::npos)
      << r.output;
  const nlohmann::json j = readJson(out("timed_out") + "/report.json");
  EXPECT_EQ(j["map_moved_by"], "own_pose");
  EXPECT_EQ(j["map_pose_field"], "time");
  const Result sheet = sh(run + " --set map_pose_field=none -q --out " + out("timed_sheet"));
  ASSERT_EQ(sheet.code, 0) << sheet.output;
  const nlohmann::json k = readJson(out("timed_sheet") + "/report.json");
  EXPECT_EQ(k["map_moved_by"], "rubber_sheet");
  const nlohmann::json& rebuilt = j["map_vs_truth"]["rubbersheet"];
  const nlohmann::json& warped = k["map_vs_truth"]["rubbersheet"];
  std::printf("rebuilt: RMSE %.4f MAX %.4f m; the sheet: RMSE %.4f MAX %.4f m\n",
              rebuilt["rmse"].get<double>(), rebuilt["max"].get<double>(),
              warped["rmse"].get<double>(), warped["max"].get<double>());
  EXPECT_LT(rebuilt["rmse"].get<double>(), 0.95 * warped["rmse"].get<double>());
  EXPECT_LE(rebuilt["max"].get<double>(), warped["max"].get<double>());
  const Result bad = sh(run + " --set map_pose_field=intensity -q --out " + out("timed_bad"));
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.output.find(drive + "/map.pcd: map_pose_field 'intensity' is neither float64 (a "
                                    "time) nor an integer (a pose's index): type 7, count 1"),
            std::string::npos)
      << bad.output;
  EXPECT_FALSE(fs::exists(out("timed_bad") + "/map_georeferenced.pcd"));
}

/// A keyframe SLAM's dump (simulate_drive --keyframes: a folder per keyframe with its pose and
/// its points in its own frame) with the GNSS of a text file or a bag: the keyframes are the
/// trajectory and the map is rebuilt from them, as close to its truth as the map whose points
/// carry their time, and closer than the sheet's; with point sigmas that hold the truth.
TEST_F(Tools, AKeyframeDumpIsTheTrajectoryAndItsMapIsRebuilt) {
  const std::string drive = out("dump");
  ASSERT_TRUE(simulate(drive, "--scenario loop_unclosed --map-points 100000 --seed 5 --keyframes"));
  const pcl::PCLPointCloud2 truth = readPcd(drive + "/truth_map.pcd");
  const auto error = [&](const std::string& o) { return againstTruth(o, truth); };
  const std::string tail =
      " --keyframes " + drive + "/keyframes" + datum() + " --set report_png=false --point-sigma";
  const Result r = sh(bin("georeference") + " --gnss " + drive + "/gnss.txt" + tail + " --out " +
                      out("dump_out"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("100000 points of a keyframe dump rebuilt, each keyframe with its own "
                          "pose (0 naming none, 0 NaN kept)"),
            std::string::npos)
      << r.output;
  const Result sheet = sh(bin("georeference") + " -q --gnss " + drive + "/gnss.txt --poses " +
                          drive + "/slam_trajectory.txt --map " + drive + "/map.pcd" + datum() +
                          " --set report_png=false --out " + out("dump_sheet"));
  ASSERT_EQ(sheet.code, 0) << sheet.output;
  const ErrorStats rebuilt = error(out("dump_out"));
  expectCloserThanTheSheet("keyframes", rebuilt, error(out("dump_sheet")), 100000);
  // The bag's fixes (its odometry left unread) give the same map.
  const Result bag = sh(bin("georeference") + " -q --bag " + drive + "/drive.bag" + tail +
                        " --out " + out("dump_bag"));
  ASSERT_EQ(bag.code, 0) << bag.output;
  EXPECT_LT(error(out("dump_bag")).rmse, 1.1 * rebuilt.rmse);
  // The sigmas: 95 % of the points within 2.45 sigma_h of their truth, give or take.
  const pcl::PCLPointCloud2 map = readPcd(out("dump_out") + "/map_georeferenced.pcd");
  const XyzLayout lm = xyzLayout(map, "map"), lt = xyzLayout(truth, "truth");
  std::size_t sigma_at = 0, within = 0;
  for (const auto& f : map.fields) sigma_at = f.name == "sigma_h" ? f.offset : sigma_at;
  ASSERT_GT(sigma_at, 0u);
  for (std::size_t i = 0; i < lm.points; ++i) {
    float h;
    std::memcpy(&h, map.data.data() + i * lm.point_step + sigma_at, 4);
    const Eigen::Vector3d e =
        lm.get(map.data.data() + i * lm.point_step) - lt.get(truth.data.data() + i * lt.point_step);
    within += e.head<2>().norm() <= 2.45 * h ? 1 : 0;
  }
  const double share = 100.0 * static_cast<double>(within) / static_cast<double>(lm.points);
  std::printf("keyframes rebuilt: %.1f %% within 2.45 sigma_h\n", share);
  EXPECT_GE(share, 85.0);
  const Result both = sh(bin("georeference") + " -q --gnss " + drive + "/gnss.txt --map " + drive +
                         "/map.pcd" + tail + " --out " + out("dump_both"));
  EXPECT_EQ(both.code, 2);
  EXPECT_NE(both.output.find("--keyframes gives the poses and the map: no --poses, --map or "
                             "--truth"),
            std::string::npos)
      << both.output;
}

/// A bag with the SLAM's registered scans (simulate_drive --scans: one PointCloud2 a pose, in
/// the map frame): --scan-topic makes the map of them, each point rebuilt with its scan's pose,
/// closer to its truth than the sheet's on the same points. A topic the bag lacks is named.
TEST_F(Tools, ABagsRegisteredScansMakeTheMapRebuiltFromTheirPoses) {
  const std::string drive = out("scans");
  ASSERT_TRUE(simulate(drive, "--scenario loop_unclosed --map-points 100000 --seed 5 --scans"));
  const std::string run =
      bin("georeference") + " --bag " + drive + "/drive.bag" + datum() + " --set report_png=false";
  const Result r = sh(run + " --scan-topic /scans --out " + out("scans_out"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("100000 points rebuilt, each with its own pose (field 'scan_time'"),
            std::string::npos)
      << r.output;
  const Result sheet = sh(run + " -q --map " + drive + "/map.pcd --out " + out("scans_sheet"));
  ASSERT_EQ(sheet.code, 0) << sheet.output;
  const pcl::PCLPointCloud2 truth = readPcd(drive + "/truth_map.pcd");
  const auto error = [&](const std::string& o) { return againstTruth(o, truth); };
  const ErrorStats rebuilt = error(out("scans_out"));
  expectCloserThanTheSheet("scans", rebuilt, error(out("scans_sheet")), 100000);
  // The same scans as the LiDAR saw them, in the body's frame: placed by the SLAM's poses first.
  const std::string body = out("body_scans");
  ASSERT_TRUE(simulate(body, "--scenario loop_unclosed --map-points 100000 --seed 5 --body-scans"));
  const Result b = sh(bin("georeference") + " -q --bag " + body + "/drive.bag" + datum() +
                      " --set report_png=false --scan-topic /scans --out " + out("body_out"));
  ASSERT_EQ(b.code, 0) << b.output;
  const ErrorStats from_body = error(out("body_out"));
  std::printf("body-frame scans rebuilt: RMSE %.4f MAX %.4f m\n", from_body.rmse, from_body.max);
  EXPECT_LT(from_body.rmse, 1.05 * rebuilt.rmse);
  EXPECT_LT(from_body.max, 1.1 * rebuilt.max);
  const Result missing = sh(run + " -q --scan-topic /points --out " + out("scans_missing"));
  EXPECT_EQ(missing.code, 1);
  EXPECT_NE(missing.output.find(drive + "/drive.bag: topic /points is not in the bag"),
            std::string::npos)
      << missing.output;
  EXPECT_FALSE(fs::exists(out("scans_missing")));
}

TEST_F(Tools, BagWithMapGivesEveryOutputAndAccurateMap) {
  const std::string o = out("bag");
  const Result r = sh(bin("georeference") + " --bag " + sim() + "/drive.bag --map " + sim() +
                      "/map.pcd --truth " + sim() + "/truth_map.pcd --out " + o + datum());
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* f :
       {"map_georeferenced.pcd", "trajectory_gnss.txt", "trajectory_slam.txt",
        "trajectory_aligned.txt", "trajectory_rubbersheet.txt", "control_points.txt", "origin.yaml",
        "report.json", "trajectory_fused.txt", "gnss_fixes.txt", "trajectory_sigma.txt"}) {
    EXPECT_TRUE(fs::exists(o + "/" + f)) << f;
  }
  for (const auto& e : fs::directory_iterator(o)) {
    EXPECT_EQ(e.path().filename().string().find(".flexcloud-staging"), std::string::npos);
  }
  const auto j = readJson(o + "/report.json");
  EXPECT_EQ(j["counts"]["map_points"], 50000);
  EXPECT_EQ(j["counts"]["control_points"], 200);
  EXPECT_EQ(j["counts"]["points_outside"], 0);
  EXPECT_EQ(j["counts"]["poses"], j["counts"]["poses_matched"]);
  EXPECT_DOUBLE_EQ(j["datum"]["lat"].get<double>(), 48.262);
  EXPECT_LE(j["map_vs_truth"]["rubbersheet"]["rmse"].get<double>(), 0.25);
  EXPECT_GT(j["map_vs_truth"]["aligned"]["rmse"].get<double>(), 1.0);
  EXPECT_LT(j["metrics"]["rubbersheet"]["mae"].get<double>(), 0.1);
  EXPECT_EQ(j["T_enu_map"].size(), 4u);
  expectSigmasCoverTheTruth(sim(), o, r.output, j);
  // A control point on the fused trajectory takes its pose's sigma (3D) as its std-dev.
  const auto sig = readRows(o + "/trajectory_sigma.txt");
  const auto cps = readRows(o + "/control_points.txt");
  ASSERT_EQ(cps.size(), 200u);
  for (const auto& cp : cps) {
    const auto& s = sig[static_cast<std::size_t>(cp[0])];
    EXPECT_NEAR(cp[8], std::sqrt(2.0 * s[1] * s[1] + s[2] * s[2]), 2e-4);
    EXPECT_GT(cp[8], 0.0);
  }
  // What the fusion did with the GNSS: every fix accounted for, the estimates reported.
  const auto& fu = j["fusion"];
  const std::size_t judged = fu["fixes_used"].get<std::size_t>() +
                             fu["fixes_rejected"]["outlier"].get<std::size_t>() +
                             fu["fixes_rejected"]["above_std_threshold"].get<std::size_t>() +
                             fu["fixes_rejected"]["excluded_range"].get<std::size_t>() +
                             fu["fixes_rejected"]["outside_poses"].get<std::size_t>();
  EXPECT_EQ(judged, j["counts"]["fixes_used"].get<std::size_t>());
  EXPECT_NEAR(fu["time_offset_s"].get<double>(), 0.0, 0.02);
  EXPECT_EQ(fu["lever_arm_m"].size(), 3u);
  EXPECT_TRUE(fu["estimated_std_h_m"].is_null());         // every simulated fix has its covariance
  EXPECT_LT(fu["slam_noise_scale"].get<double>(), 1.05);  // not raised (a raise is >= 1.5x)
  EXPECT_NEAR(fu["gnss_roughness_h_m"].get<double>(), 0.015, 0.01);  // simulated noise 0.015 m
  EXPECT_GT(j["beside_points"]["used"].get<int>(), 200);
  std::ifstream fixes(o + "/gnss_fixes.txt");
  std::size_t lines = 0, used = 0;
  for (std::string line; std::getline(fixes, line);) {
    if (line.empty() || line[0] == '#') continue;
    ++lines;
    std::istringstream fields(line);
    std::vector<std::string> f{std::istream_iterator<std::string>(fields), {}};
    ASSERT_EQ(f.size(), 13u) << line;
    EXPECT_EQ(f[12], "given") << line;  // every simulated fix has its covariance
    if (f[6] != "used") continue;
    ++used;
    // Its own std-dev (the simulated receiver's, RTK), the SLAM's jitter (none on a simulated
    // drive) and the SLAM's interpolation are given beside the verdict.
    EXPECT_GT(std::stod(f[7]), 0.0) << line;
    EXPECT_LT(std::stod(f[7]), 0.1) << line;
    EXPECT_LT(std::stod(f[9]), 0.05) << line;
    EXPECT_LT(std::stod(f[11]), 0.05) << line;  // odometry at 10 Hz: nothing to interpolate
  }
  EXPECT_EQ(lines, judged);
  EXPECT_EQ(used, fu["fixes_used"].get<std::size_t>());
  const pcl::PCLPointCloud2 in = readPcd(sim() + "/map.pcd");
  const pcl::PCLPointCloud2 warped = readPcd(o + "/map_georeferenced.pcd");
  EXPECT_EQ(warped.width * warped.height, 50000u);
  ASSERT_EQ(warped.fields.size(), in.fields.size());
  for (std::size_t i = 0; i < in.fields.size(); ++i) {
    EXPECT_EQ(warped.fields[i].name, in.fields[i].name);
    EXPECT_EQ(warped.fields[i].datatype, in.fields[i].datatype);
  }
  EXPECT_NE(r.output.find("map vs truth"), std::string::npos);
}

/// A truth map is only compared in its own ENU frame: without its datum, or with a run in
/// another datum, the tool refuses in one line instead of reporting metres of error that are
/// not there.
TEST_F(Tools, ATruthIsComparedInItsOwnFrameOnly) {
  const std::string run = bin("georeference") + " -q --bag " + sim() + "/drive.bag --map " + sim() +
                          "/map.pcd --out " + out("truth_frame");
  const Result other = sh(run + " --truth " + sim() + "/truth_map.pcd");  // datum: first fix
  EXPECT_EQ(other.code, 1) << other.output;
  EXPECT_NE(other.output.find("the truth is in the ENU frame of the datum 48.262000000 "
                              "11.667000000 480.0000, this run's datum is another; give --datum"),
            std::string::npos)
      << other.output;
  const std::string lone = out("lone_truth.pcd");
  fs::copy_file(sim() + "/truth_map.pcd", lone, fs::copy_options::overwrite_existing);
  const Result none = sh(run + datum() + " --truth " + lone);
  EXPECT_EQ(none.code, 2) << none.output;
  EXPECT_NE(none.output.find("give the datum it was made in (--truth-datum LAT LON ALT"),
            std::string::npos)
      << none.output;
  const Result given =
      sh(run + datum() + " --truth " + lone + " --truth-datum 48.2620 11.6670 480");
  EXPECT_EQ(given.code, 0) << given.output;
  EXPECT_LT(readJson(out("truth_frame") + "/report.json")["map_vs_truth"]["rubbersheet"]["rmse"]
                .get<double>(),
            0.3);
}

TEST_F(Tools, TextFilesGiveTheSameGeoreferencing) {
  const std::string a = out("text"), b = out("bag2");
  ASSERT_EQ(sh(bin("georeference") + " --gnss " + sim() + "/gnss.txt --poses " + sim() +
               "/slam_trajectory.txt -q --out " + a + datum())
                .code,
            0);
  ASSERT_EQ(sh(bin("georeference") + " --bag " + sim() + "/drive.bag -q --out " + b + datum()).code,
            0);
  const auto ja = readJson(a + "/report.json"), jb = readJson(b + "/report.json");
  // The text file rounds the fixes to 1e-10 deg (1 cm) and 0.1 mm: results agree to that.
  EXPECT_NEAR(ja["metrics"]["rubbersheet"]["mae"].get<double>(),
              jb["metrics"]["rubbersheet"]["mae"].get<double>(), 0.01);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(ja["T_enu_map"][i][3].get<double>(), jb["T_enu_map"][i][3].get<double>(), 0.01);
  }
  EXPECT_FALSE(fs::exists(a + "/map_georeferenced.pcd"));  // no map given, none written
}

/// Rewrites a text table: `header` first (if any), then every row with its columns passed
/// through `change` and joined by `sep`.
void rewriteRows(const std::string& from, const std::string& to,
                 const std::function<void(std::vector<std::string>&)>& change,
                 const std::string& header = "", const std::string& sep = " ") {
  std::ifstream in(from);
  std::ofstream o(to);
  if (!header.empty()) o << header << "\n";
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::vector<std::string> row{std::istream_iterator<std::string>(fields), {}};
    change(row);
    for (std::size_t i = 0; i < row.size(); ++i) o << (i ? sep : "") << row[i];
    o << "\n";
  }
}

/// GNSS as CSV with a header and nanosecond stamps written as floats; poses with a header,
/// stamped in milliseconds from 0. The errors say what to give, and with it the run is the
/// run on the plain files.
TEST_F(Tools, TextFilesAsUsersWriteThem) {
  const std::string csv = out("gnss_ns.csv"), tum = out("poses_ms.txt");
  rewriteRows(
      sim() + "/gnss.txt", csv,
      [](std::vector<std::string>& row) { row[0] = std::to_string(std::stod(row[0]) * 1e9); },
      "stamp,lat,lon,alt,std_e,std_n,std_u", ",");
  double first = NAN;
  rewriteRows(
      sim() + "/slam_trajectory.txt", tum,
      [&](std::vector<std::string>& row) {
        const double t = std::stod(row[0]);
        if (std::isnan(first)) first = t;
        row[0] = std::to_string(std::llround((t - first) * 1e3));
      },
      "# poses\ntimestamp x y z qx qy qz qw");
  const std::string run = bin("georeference") + " -q --gnss " + csv + " --poses " + tum + datum();
  const Result unit = sh(run + " --out " + out("units"));
  EXPECT_EQ(unit.code, 1) << unit.output;
  EXPECT_NE(unit.output.find("are the poses' stamps in ms? (the tool's --poses-stamp-unit)"),
            std::string::npos)
      << unit.output;
  const Result offset = sh(run + " --poses-stamp-unit ms --out " + out("units"));
  EXPECT_EQ(offset.code, 1) << offset.output;
  const std::string says = "if the two clocks differ by a constant, gnss_time_offset ";
  const std::size_t at = offset.output.find(says);
  ASSERT_NE(at, std::string::npos) << offset.output;
  const double given = std::stod(offset.output.substr(at + says.size()));
  EXPECT_NEAR(given, -first, 1.0) << "the GNSS starts about when the poses do";
  const Result ok =
      sh(run + " --poses-stamp-unit ms --set gnss_time_offset=" + std::to_string(-first) +
         " --out " + out("units"));
  ASSERT_EQ(ok.code, 0) << ok.output;
  const std::string plain = out("plain_text");
  ASSERT_EQ(sh(bin("georeference") + " -q --gnss " + sim() + "/gnss.txt --poses " + sim() +
               "/slam_trajectory.txt --out " + plain + datum())
                .code,
            0);
  const auto a = readJson(out("units") + "/report.json"), b = readJson(plain + "/report.json");
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(a["T_enu_map"][i][3].get<double>(), b["T_enu_map"][i][3].get<double>(), 0.01);
  }
  EXPECT_NEAR(a["metrics"]["rubbersheet"]["mae"].get<double>(),
              b["metrics"]["rubbersheet"]["mae"].get<double>(), 0.01);
}

/// Ordinary GNSS (1 m horizontally, 2 m vertically, as the receiver reports) with the defaults:
/// the fusion weighs every fix and the map lies within 0.3 m of the truth; without the fusion,
/// the threshold's error gives the fixes' std-devs and a value that works.
TEST_F(Tools, OrdinaryGnssWorksWithTheDefaults) {
  const std::string drive = out("ordinary");
  ASSERT_TRUE(simulate(drive, "--gnss-noise 1.0 2.0 --map-points 50000 --seed 3"));
  const std::string run = bin("georeference") + " -q --bag " + drive + "/drive.bag --map " + drive +
                          "/map.pcd --truth " + drive + "/truth_map.pcd" + datum() +
                          " --set report_png=false --out " + out("ordinary_out");
  const Result r = sh(run);
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json report = readJson(out("ordinary_out") + "/report.json");
  const double rmse = report["map_vs_truth"]["rubbersheet"]["rmse"].get<double>();
  std::printf("ordinary GNSS, defaults: map RMSE %.3f m against the truth\n", rmse);
  EXPECT_LT(rmse, 0.3);
  EXPECT_NE(r.output.find("warning        stddev_threshold 0.100 m leaves 0 of "),
            std::string::npos)
      << r.output;
  const Result simple = sh(run + " --set fusion=false");
  EXPECT_EQ(simple.code, 1) << simple.output;
  EXPECT_NE(simple.output.find("median 1.000 m, 95th percentile"), std::string::npos)
      << simple.output;
  const std::size_t at = simple.output.find("; stddev_threshold ");
  ASSERT_NE(at, std::string::npos) << simple.output;
  const double works = std::stod(simple.output.substr(at + 19));
  EXPECT_EQ(sh(run + " --set fusion=false --stddev-threshold " + std::to_string(works)).code, 0);
}

/// Latitude and longitude swapped in a GNSS file: the run fails naming it, and nothing is
/// written.
TEST_F(Tools, SwappedLatitudeAndLongitudeAreNamed) {
  const std::string gnss = out("swapped_gnss.txt"), o = out("swapped");
  rewriteRows(sim() + "/gnss.txt", gnss,
              [](std::vector<std::string>& row) { std::swap(row[1], row[2]); });
  const Result r = sh(bin("georeference") + " -q --gnss " + gnss + " --poses " + sim() +
                      "/slam_trajectory.txt --out " + o);
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_EQ(r.output.rfind("georeference: GNSS: latitude and longitude look swapped: the SLAM's "
                           "track fits the fixes to ",
                           0),
            0u)
      << r.output;
  EXPECT_NE(r.output.find(" (the first fix reads latitude 11.6"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("; give them as latitude, longitude\n"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(o + "/report.json"));
}

/// Poses 20 % too large (a SLAM not in metres): the rigid scale shows a result that cannot be
/// right; the run fails naming it, or with --accept-degraded writes it marked degraded.
TEST_F(Tools, ADegradedResultFailsUnlessAccepted) {
  const std::string poses = out("scaled_poses.txt"), o = out("degraded");
  rewriteRows(sim() + "/slam_trajectory.txt", poses, [](std::vector<std::string>& row) {
    for (int a = 1; a <= 3; ++a) row[a] = std::to_string(1.2 * std::stod(row[a]));
  });
  const std::string run = bin("georeference") + " -q --gnss " + sim() + "/gnss.txt --poses " +
                          poses + " --map " + sim() + "/map.pcd --set report_png=false --out " + o;
  const Result refused = sh(run);
  EXPECT_EQ(refused.code, 1) << refused.output;
  EXPECT_EQ(refused.output.rfind("georeference: the result cannot be right: the GNSS's track is "
                                 "0.83",
                                 0),
            0u)
      << refused.output;
  EXPECT_NE(refused.output.find(" times the SLAM's (rigid scale): beyond any SLAM's scale error "
                                "(are the GNSS of this drive and the poses in metres?) "
                                "(accept_degraded true, or the tool's --accept-degraded, keeps "
                                "it, marked degraded in report.json)\n"),
            std::string::npos)
      << refused.output;
  EXPECT_FALSE(fs::exists(o + "/report.json"));
  const Result kept = sh(run + " --accept-degraded");
  ASSERT_EQ(kept.code, 0) << kept.output;
  EXPECT_NE(kept.output.find("warning        degraded: the GNSS's track is 0.83"),
            std::string::npos)
      << kept.output;
  const nlohmann::json report = readJson(o + "/report.json");
  EXPECT_TRUE(report["degraded"].get<bool>());
  ASSERT_GE(report["degraded_reasons"].size(), 1u);
  EXPECT_EQ(report["degraded_reasons"][0].get<std::string>().rfind("the GNSS's track is 0.83", 0),
            0u);
  EXPECT_TRUE(fs::exists(o + "/map_georeferenced.pcd"));
  // A sound run says it is not degraded.
  ASSERT_EQ(sh(bin("georeference") + " -q --bag " + sim() + "/drive.bag --set report_png=false " +
               "--out " + o)
                .code,
            0);
  EXPECT_FALSE(readJson(o + "/report.json")["degraded"].get<bool>());
}

// Wherever no clock offset was applied, report.json says why: with the fusion, without it, and
// with none asked for.
TEST_F(Tools, TheClockSaysWhyItWasNotEstimated) {
  for (const std::string set : {"", " --set fusion=false", " --set max_time_offset=0"}) {
    const std::string o = out("clock" + std::to_string(set.size()));
    const Result run =
        sh(bin("georeference") + " --bag " + sim() + "/drive.bag -q" + set + " --out " + o);
    ASSERT_EQ(run.code, 0) << set;
    const nlohmann::json clock = readJson(o + "/report.json")["clock"];
    ASSERT_TRUE(clock.contains("estimated")) << set;
    // The summary's lead line says which offset was applied.
    char applied[96];
    if (clock["estimated"].get<bool>()) {
      std::snprintf(applied, sizeof(applied), ", clock offset %+.1f +- %.1f ms\n",
                    1e3 * clock["offset_s"].get<double>(),
                    1e3 * clock["offset_sigma_s"].get<double>());
    } else {
      std::snprintf(applied, sizeof(applied), ", clock offset %+.1f ms as given\n",
                    1e3 * clock["offset_s"].get<double>());
    }
    EXPECT_NE(run.output.find(applied), std::string::npos) << applied << run.output;
    if (clock["estimated"].get<bool>()) continue;
    ASSERT_TRUE(clock.contains("why_not_estimated")) << set << clock.dump();
    EXPECT_FALSE(clock["why_not_estimated"].get<std::string>().empty()) << set;
    if (set == " --set max_time_offset=0") {
      EXPECT_EQ(clock["why_not_estimated"],
                "max_time_offset is 0: no offset asked for (gnss_time_offset applied)");
    }
  }
}

TEST_F(Tools, ConfigFileAndFlagsSetTheParameters) {
  const std::string cfg = out("cfg.yaml");
  std::ofstream(cfg) << "control_points: 50\nstddev_threshold: 0.2\n";
  const std::string o = out("cfg");
  ASSERT_EQ(
      sh(bin("georeference") + " --bag " + sim() + "/drive.bag -q --config " + cfg + " --out " + o)
          .code,
      0);
  EXPECT_EQ(readJson(o + "/report.json")["counts"]["control_points_requested"], 50);
  EXPECT_DOUBLE_EQ(readJson(o + "/report.json")["params"]["stddev_threshold"].get<double>(), 0.2);
  ASSERT_EQ(sh(bin("georeference") + " --bag " + sim() + "/drive.bag -q --config " + cfg +
               " --control-points 30 --out " + o)
                .code,
            0);  // the flag wins over the file
  const nlohmann::json flagged = readJson(o + "/report.json");
  EXPECT_EQ(flagged["counts"]["control_points_requested"], 30);
  // The simulated drive keeps an even speed: the clock is not told, and only that is said.
  for (const std::string w : flagged["warnings"]) {
    EXPECT_EQ(w.rfind("clock: ", 0), 0u) << w;
  }
  // More than the drive's poses can carry: capped, and the report says so.
  ASSERT_EQ(sh(bin("georeference") + " --bag " + sim() + "/drive.bag -q --control-points 50000 " +
               "--out " + o)
                .code,
            0);
  const nlohmann::json report = readJson(o + "/report.json");
  const int placed = report["counts"]["control_points"];
  EXPECT_LT(placed, 50000);
  bool said = false;
  for (const std::string w : report["warnings"]) {
    said = said ||
           w.rfind("control_points 50000 asked for, " + std::to_string(placed) + " placed", 0) == 0;
  }
  EXPECT_TRUE(said) << report["warnings"].dump();
}

TEST_F(Tools, BadInputIsAOneLineErrorAndKeepsPreviousOutputs) {
  const std::string o = out("keep");
  fs::create_directories(o);
  std::ofstream(o + "/report.json") << "{\"previous\": true}\n";
  struct Case {
    std::string args;
    int code;
    std::string says;
  };
  std::ofstream(out("empty.pcd")) << "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 0\nHEIGHT 1\n"
                                     "POINTS 0\nDATA binary\n";
  const std::vector<Case> cases = {
      {"--bag " + sim() + "/drive.bag --map " + out("empty.pcd"), 1, "the map holds no points"},
      {"--bag /nonexistent.bag", 1, "--bag /nonexistent.bag: no such file"},
      {"--bag " + sim() + "/drive.bag --map /nonexistent.pcd", 1,
       "--map /nonexistent.pcd: no such file"},
      {"--bag " + sim() + " --map " + sim() + "/map.pcd", 1, "is a folder, not a file"},
      {"--bag " + sim() + "/drive.bag --gnss-stamp-unit min", 2, "--gnss-stamp-unit: stamp unit"},
      {"--bag " + sim() + "/drive.bag --fix-topic /gps", 1, "topic /gps is not in the bag"},
      {"--bag " + sim() + "/drive.bag --fix-topic /odom", 1, "holds nav_msgs/Odometry"},
      {"--bag " + sim() + "/map.pcd", 1, "not a rosbag (version 2.0) file"},
      {"--bag " + sim() + "/drive.bag --map " + sim() + "/gnss.txt", 1, "not a PCD file"},
      {"--bag " + sim() + "/drive.bag --control-points 2", 1, "control_points 2 is not in"},
      {"--bag " + sim() + "/drive.bag --set no_such=1", 1, "unknown parameter 'no_such'"},
      {"--gnss " + sim() + "/gnss.txt --poses " + sim() + "/gnss.txt", 1, "gnss.txt:2: expected"},
      {"--gnss " + sim() + "/gnss.txt", 2, "--poses"},
      {"--bogus", 2, "unknown option '--bogus'"},
  };
  for (const auto& c : cases) {
    const Result r = sh(bin("georeference") + " -q --out " + o + " " + c.args);
    EXPECT_EQ(r.code, c.code) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  // A missing map is named before the bag is read.
  const Result early =
      sh(bin("georeference") + " --out " + o + " --bag " + sim() + "/drive.bag --map /no.pcd");
  EXPECT_EQ(early.output, "georeference: --map /no.pcd: no such file\n");
  EXPECT_EQ(readJson(o + "/report.json")["previous"], true);
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(o)) files += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 1u);
  for (const auto& e : fs::directory_iterator(o)) EXPECT_FALSE(e.is_directory()) << e.path();
}

/// An ascii map goes through the tool streamed, like a binary one, to the same result; a bad
/// line deep in it, or a body cut short, ends the run with its place named and no output.
TEST_F(Tools, AsciiMapsAreStreamedAndTheirBadLinesNamed) {
  const pcl::PCLPointCloud2 map = readPcd(sim() + "/map.pcd");
  const std::string ascii = out("ascii_map.pcd");
  ASSERT_EQ(pcl::PCDWriter().writeASCII(ascii, map), 0);
  EXPECT_LT(warpedAgainstBinary(ascii, "ascii"), 1e-3)
      << "the ascii text rounds the input a little";
  const XyzLayout la = xyzLayout(map, "map");
  const std::string args = " -q --bag " + sim() + "/drive.bag" + datum() + " --map ";
  EXPECT_EQ(readJson(out("ascii") + "/report.json")["counts"]["map_points"], la.points);

  std::ifstream in(ascii);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const std::size_t header = lines.size() - la.points;
  const std::size_t bad = header + 40000;  // line bad + 1 of the file
  std::vector<std::string> broken = lines;
  std::istringstream values(lines[bad]);
  std::vector<std::string> v{std::istream_iterator<std::string>(values), {}};
  v[2] = "oops";  // the z value
  broken[bad].clear();
  for (const auto& x : v) broken[bad] += x + " ";
  std::ofstream(out("bad_line.pcd")) << [&] {
    std::string t;
    for (const auto& l : broken) t += l + "\n";
    return t;
  }();
  std::ofstream cut(out("cut.pcd"));
  for (std::size_t i = 0; i < lines.size() - 10; ++i) cut << lines[i] << "\n";
  cut.close();
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"bad_line.pcd", "bad_line.pcd:" + std::to_string(bad + 1) + ": 'oops' is not a value"},
      {"cut.pcd", "holds " + std::to_string(la.points - 10) + " points, the header " +
                      std::to_string(la.points) + " (file cut short?)"}};
  for (const auto& [file, says] : cases) {
    const std::string o = out("none_" + file);
    const Result r = sh(bin("georeference") + args + out(file) + " --out " + o);
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    EXPECT_FALSE(fs::exists(o)) << "nothing may be left behind";
  }
}

/// A binary_compressed map is streamed too (its LZF block decoded a piece at a time) to the
/// same points as the binary map; a corrupt block ends the run with no output.
TEST_F(Tools, CompressedMapsAreStreamedAndCorruptOnesRefused) {
  const pcl::PCLPointCloud2 map = readPcd(sim() + "/map.pcd");
  const std::string packed = out("compressed_map.pcd");
  ASSERT_EQ(pcl::PCDWriter().writeBinaryCompressed(packed, map), 0);
  EXPECT_EQ(warpedAgainstBinary(packed, "compressed"), 0.0)
      << "the same float32 inputs, the same result";
  const std::string args = " -q --bag " + sim() + "/drive.bag" + datum() + " --map ";

  std::string bytes;
  {
    std::ifstream in(packed, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::size_t body = bytes.find("DATA binary_compressed\n") + 23 + 8;
  for (std::size_t i = body; i < body + 64; ++i) bytes[i] = '\xff';  // references before the start
  std::ofstream(out("corrupt.pcd"), std::ios::binary) << bytes;
  const Result r = sh(bin("georeference") + args + out("corrupt.pcd") + " --out " + out("none_c"));
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("corrupt.pcd: the compressed body is corrupt"), std::string::npos)
      << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_FALSE(fs::exists(out("none_c")));
}

/// Runs the tool, sends `sig` when it reports the warp, returns its exit code and stderr.
Result interruptDuringWarp(const std::vector<std::string>& args, int sig) {
  int fds[2];
  if (::pipe(fds) != 0) return {-1, "pipe failed"};
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(fds[1], 2);
    ::close(fds[0]);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  Result r{-1, ""};
  bool sent = false;
  char buf[4096];
  ssize_t n;
  while ((n = ::read(fds[0], buf, sizeof(buf))) > 0) {
    r.output.append(buf, static_cast<std::size_t>(n));
    if (!sent && r.output.find("warping") != std::string::npos) {
      ::kill(pid, sig);
      sent = true;
    }
  }
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

TEST_F(Tools, AnInterruptedWarpLeavesThePreviousOutputs) {
  const std::string big = out("big");
  ASSERT_EQ(sh(bin("simulate_drive") + " --out " + big + " --map-points 4000000 --seed 9").code, 0);
  for (int sig : {SIGINT, SIGTERM}) {
    const std::string o = out("interrupted" + std::to_string(sig));
    fs::create_directories(o);
    std::ofstream(o + "/report.json") << "{\"previous\": true}\n";
    std::ofstream(o + "/map_georeferenced.pcd") << "previous map\n";
    const Result r = interruptDuringWarp(
        {bin("georeference"), "--bag", big + "/drive.bag", "--map", big + "/map.pcd", "--out", o,
         "--control-points", "2000", "--threads", "1"},
        sig);
    EXPECT_EQ(r.code, 130) << r.output;
    EXPECT_NE(r.output.find("cancelled"), std::string::npos) << r.output;
    EXPECT_EQ(readJson(o + "/report.json")["previous"], true);
    std::ifstream map(o + "/map_georeferenced.pcd");
    std::string first;
    std::getline(map, first);
    EXPECT_EQ(first, "previous map");
    std::size_t entries = 0;
    for (const auto& e : fs::directory_iterator(o)) ++entries, (void)e;
    EXPECT_EQ(entries, 2u) << "nothing else may be left behind";
  }
}

/// kill -9 in the middle of the map leaves its staging folder; the next run into the folder
/// removes it, and leaves only its own outputs: the earlier map it did not write goes, the
/// user's own file stays.
TEST_F(Tools, AKilledRunLeavesNothingTheNextRunKeeps) {
  const std::string big = out("big_killed");
  ASSERT_EQ(sh(bin("simulate_drive") + " --out " + big + " --map-points 2000000 --seed 9").code, 0);
  const std::string o = out("killed");
  fs::create_directories(o);
  std::ofstream(o + "/notes.txt") << "the user's\n";
  const Result r = interruptDuringWarp({bin("georeference"), "--bag", big + "/drive.bag", "--map",
                                        big + "/map.pcd", "--out", o, "--threads", "1"},
                                       SIGKILL);
  EXPECT_EQ(r.code, -1) << r.output;
  auto staging = [&] {
    std::size_t n = 0;
    for (const auto& e : fs::directory_iterator(o)) {
      n += e.path().filename().string().rfind(".flexcloud-staging-", 0) == 0 ? 1 : 0;
    }
    return n;
  };
  EXPECT_EQ(staging(), 1u);  // what kill -9 leaves
  ASSERT_EQ(sh(bin("georeference") + " -q --bag " + sim() + "/drive.bag --map " + sim() +
               "/map.pcd --out " + o + datum())
                .code,
            0);
  EXPECT_EQ(staging(), 0u);
  EXPECT_TRUE(fs::exists(o + "/map_georeferenced.pcd"));
  // A run without a map into the same folder: the map of the run before is not its output.
  const Result t = sh(bin("georeference") + " -q --gnss " + sim() + "/gnss.txt --poses " + sim() +
                      "/slam_trajectory.txt --out " + o + datum());
  ASSERT_EQ(t.code, 0) << t.output;
  EXPECT_FALSE(fs::exists(o + "/map_georeferenced.pcd"));
  EXPECT_TRUE(fs::exists(o + "/report.json"));
  EXPECT_EQ(readJson(o + "/report.json")["counts"]["map_points"], 0);
  std::ifstream notes(o + "/notes.txt");
  std::string line;
  std::getline(notes, line);
  EXPECT_EQ(line, "the user's");
}

/// A full disk: the error names the folder the user gave (not the staging folder inside it),
/// and nothing is left there.
TEST_F(Tools, AFullDiskIsNamedByTheUsersFolder) {
  const std::string mnt = out("small_disk");
  fs::create_directories(mnt);
  if (sh("mount -t tmpfs -o size=96k tmpfs " + mnt).code != 0) {
    GTEST_SKIP() << "cannot mount a small tmpfs here (needs root); skipped";
  }
  const std::string o = mnt + "/result";
  const Result r = sh(bin("georeference") + " -q --bag " + sim() + "/drive.bag --map " + sim() +
                      "/map.pcd --out " + o + datum());
  std::size_t left = 0;
  for (const auto& e : fs::directory_iterator(mnt)) ++left, (void)e;
  sh("umount " + mnt);
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_EQ(r.output.rfind("georeference: " + o + "/", 0), 0u) << r.output;
  EXPECT_EQ(r.output.find(".flexcloud-staging"), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_EQ(left, 0u) << "the folder the run made is removed again";
}

TEST_F(Tools, SimulatorRejectsBadSettings) {
  const Result r = sh(bin("simulate_drive") + " --out " + out("badsim") + " --length -5");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.output.find("length must be in"), std::string::npos) << r.output;
  EXPECT_EQ(sh(bin("simulate_drive") + " --speed fast").code, 2);
  const Result jitter =
      sh(bin("simulate_drive") + " --out " + out("badjitter") + " --pose-jitter -0.01");
  EXPECT_EQ(jitter.code, 1);
  EXPECT_NE(jitter.output.find("SLAM pose jitter must be in [0, 1] m"), std::string::npos)
      << jitter.output;
  EXPECT_FALSE(fs::exists(out("badjitter")));
}

/// --point-sigma: every point of the map and of the Autoware tiles gains sigma_h and sigma_v
/// (float32) after its own fields, its x, y, z as without them; at least 80 % of the points lie
/// within 2.45 sigma_h of their true place; PCL's reader of x, y, z alone still reads the map; a
/// map that holds the fields already is refused before any work.
TEST_F(Tools, PointSigmasGoIntoTheMapAndItsTiles) {
  const std::string o = out("point_sigma");
  const std::string args = " -q --bag " + sim() + "/drive.bag" + datum();
  const Result r = sh(bin("georeference") + args + " --map " + sim() +
                      "/map.pcd --point-sigma --autoware --set report_png=false --out " + o);
  ASSERT_EQ(r.code, 0) << r.output;
  const pcl::PCLPointCloud2 in = readPcd(sim() + "/map.pcd");
  const pcl::PCLPointCloud2 m = readPcd(o + "/map_georeferenced.pcd");
  const pcl::PCLPointCloud2 truth = readPcd(sim() + "/truth_map.pcd");
  ASSERT_EQ(m.fields.size(), in.fields.size() + 2);
  EXPECT_EQ(m.fields[in.fields.size()].name, "sigma_h");
  EXPECT_EQ(m.fields.back().name, "sigma_v");
  EXPECT_EQ(m.fields.back().datatype, pcl::PCLPointField::FLOAT32);
  const XyzLayout lm = xyzLayout(m, "map"), lt = xyzLayout(truth, "truth");
  ASSERT_EQ(lm.points, lt.points);
  std::size_t within = 0;
  for (std::size_t i = 0; i < lm.points; ++i) {
    const std::uint8_t* pt = m.data.data() + i * lm.point_step;
    float sigma_h, sigma_v;
    std::memcpy(&sigma_h, pt + m.fields[in.fields.size()].offset, 4);
    std::memcpy(&sigma_v, pt + m.fields.back().offset, 4);
    ASSERT_TRUE(sigma_h > 0.0F && sigma_h < 10.0F && sigma_v > 0.0F) << i;
    const Eigen::Vector3d e = lm.get(pt) - lt.get(truth.data.data() + i * lt.point_step);
    within += e.head<2>().norm() <= 2.45 * sigma_h;
  }
  std::printf("points within 2.45 sigma_h: %.1f %%\n", 100.0 * within / lm.points);
  EXPECT_GE(static_cast<double>(within), 0.8 * lm.points);
  const Result plain = sh(bin("georeference") + args + " --map " + sim() +
                          "/map.pcd --set report_png=false --out " + out("no_point_sigma"));
  ASSERT_EQ(plain.code, 0) << plain.output;
  const pcl::PCLPointCloud2 p = readPcd(out("no_point_sigma") + "/map_georeferenced.pcd");
  const XyzLayout lp = xyzLayout(p, "plain");
  for (std::size_t i = 0; i < lm.points; i += 97) {
    ASSERT_EQ(lm.get(m.data.data() + i * lm.point_step), lp.get(p.data.data() + i * lp.point_step))
        << "the sigmas move no point: " << i;
  }
  pcl::PointCloud<pcl::PointXYZ> xyz;
  ASSERT_EQ(pcl::io::loadPCDFile(o + "/map_georeferenced.pcd", xyz), 0);
  EXPECT_EQ(xyz.size(), lm.points);
  const fs::path tile = fs::directory_iterator(o + "/autoware/pointcloud_map")->path();
  const pcl::PCLPointCloud2 t = readPcd(tile.string());
  EXPECT_EQ(t.fields.back().name, "sigma_v") << tile;

  // A map of another quality says so: 0.5 m of scatter is every point's floor.
  const std::string coarse = out("point_sigma_coarse");
  const Result c = sh(bin("georeference") + args + " --map " + sim() +
                      "/map.pcd --point-sigma --set point_scatter=0.5 --set report_png=false "
                      "--out " +
                      coarse);
  ASSERT_EQ(c.code, 0) << c.output;
  const pcl::PCLPointCloud2 cm = readPcd(coarse + "/map_georeferenced.pcd");
  float least = 1e9F;
  for (std::size_t i = 0; i < lm.points; ++i) {
    float sigma_h;
    std::memcpy(&sigma_h, cm.data.data() + i * lm.point_step + cm.fields[in.fields.size()].offset,
                4);
    least = std::min(least, sigma_h);
  }
  EXPECT_GE(least, 0.5F);
  EXPECT_LT(least, 0.6F);

  const Result again = sh(bin("georeference") + args + " --map " + o +
                          "/map_georeferenced.pcd --point-sigma --out " + out("twice"));
  EXPECT_EQ(again.code, 1) << again.output;
  EXPECT_NE(again.output.find("map_georeferenced.pcd: already holds a field sigma_h"),
            std::string::npos)
      << again.output;
  EXPECT_FALSE(fs::exists(out("twice")));
}

}  // namespace
}  // namespace flexcloud
