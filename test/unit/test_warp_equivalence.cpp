// The fast warp (grid, candidates, previous-point check, streaming) against the reference: the
// tetrahedron CGAL's own point location finds, on sheets from simulated drives.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include "body_copy.h"
#include "flexcloud/georeference.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/map_precopy.h"
#include "flexcloud/io/map_stream.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/sim/sim_cloud.h"
#include "flexcloud/warp/cloud_warp.h"
#include "test_util.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

struct Case {
  sim::SimDrive drive;
  GeoreferenceResult result;
};

Case makeCase(int control_points, std::size_t map_points) {
  sim::SimParams sp;
  sp.seed = 11;
  sp.map_points = map_points;
  Case c{sim::simulateDrive(sp), {}};
  Params p;
  p.control_points = control_points;
  c.result = georeference(test::inputOf(c.drive), p);
  return c;
}

/// A float64 cloud of the given map-frame points (x y z).
pcl::PCLPointCloud2 doubleCloud(const std::vector<Eigen::Vector3d>& pts) {
  using F = pcl::PCLPointField;
  pcl::PCLPointCloud2 c =
      test::packedCloud({{"x", F::FLOAT64}, {"y", F::FLOAT64}, {"z", F::FLOAT64}},
                        static_cast<std::uint32_t>(pts.size()));
  const XyzLayout l = xyzLayout(c, "probe");
  for (std::size_t i = 0; i < pts.size(); ++i) l.set(c.data.data() + i * 24, pts[i]);
  return c;
}

TEST(WarpEquivalence, FastPathMatchesCgalOnMapFacesEdgesVerticesAndOutside) {
  for (int cps : {200, 2000}) {
    const Case c = makeCase(cps, 100000);
    const RubberSheet& sheet = *c.result.sheet;
    const Eigen::Isometry3d to_map =
        c.result.T_enu_map.inverse();                        // sources are in the aligned frame
    std::vector<Eigen::Vector3d> probes = c.drive.map.slam;  // the map, in scan order
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (const auto& t : sheet.tetrahedra()) {
      const auto& s = sheet.sources();
      const Eigen::Vector3d a = s[t[0]], b = s[t[1]], d = s[t[2]];
      probes.push_back(to_map * a);                // a vertex
      probes.push_back(to_map * (0.5 * (a + b)));  // an edge midpoint
      const double x = 0.5 * u(rng), y = 0.5 * u(rng);
      probes.push_back(to_map * (a + x * (b - a) + y * (d - a)));  // a point on a face
    }
    Eigen::Vector3d lo = c.result.cuboid_enu[0], hi = c.result.cuboid_enu[7];
    for (int i = 0; i < 20000; ++i) {  // anywhere in and around the cuboid
      const Eigen::Vector3d f(u(rng) * 1.4 - 0.2, u(rng) * 1.4 - 0.2, u(rng) * 1.4 - 0.2);
      probes.push_back(to_map * (lo + f.cwiseProduct(hi - lo)));
    }
    pcl::PCLPointCloud2 cloud = doubleCloud(probes);
    const WarpStats stats = warpCloud(cloud, sheet, 2);
    EXPECT_GT(stats.outside, 1000u) << "the probes should leave the cuboid";
    const XyzLayout l = xyzLayout(cloud, "probe");
    double worst = 0.0;
    std::size_t outside = 0;
    for (std::size_t i = 0; i < probes.size(); ++i) {
      bool out = false;
      const Eigen::Vector3d want = sheet.transformReference(probes[i], &out);
      outside += out ? 1 : 0;
      worst = std::max(worst, (l.get(cloud.data.data() + i * 24) - want).norm());
    }
    EXPECT_LT(worst, 1e-6) << cps << " control points";
    // Points on the hull's faces may count as in or out; the two answers agree there.
    EXPECT_NEAR(static_cast<double>(stats.outside), static_cast<double>(outside),
                0.001 * probes.size());
  }
}

/// Maps in any order: shuffled (warped cell by cell, in Morton order) and half scan-ordered,
/// half shuffled (the warp switches between the two). Every point is CGAL's answer, in its place.
TEST(WarpEquivalence, RandomOrderMatchesCgalWithEveryPointInItsPlace) {
  const Case c = makeCase(2000, 200000);
  const RubberSheet& sheet = *c.result.sheet;
  std::vector<Eigen::Vector3d> shuffled = c.drive.map.slam;
  std::mt19937 rng(4);
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  std::vector<Eigen::Vector3d> mixed(c.drive.map.slam.begin(), c.drive.map.slam.begin() + 100000);
  mixed.insert(mixed.end(), shuffled.begin(), shuffled.begin() + 100000);
  for (const auto* probes : {&shuffled, &mixed}) {
    pcl::PCLPointCloud2 cloud = doubleCloud(*probes);
    const WarpStats stats = warpCloud(cloud, sheet, 2);
    EXPECT_EQ(stats.points, probes->size());
    const XyzLayout l = xyzLayout(cloud, "probe");
    double worst = 0.0;
    for (std::size_t i = 0; i < probes->size(); ++i) {
      const Eigen::Vector3d want = sheet.transformReference((*probes)[i]);
      worst = std::max(worst, (l.get(cloud.data.data() + i * 24) - want).norm());
    }
    EXPECT_LT(worst, 1e-6) << (probes == &shuffled ? "shuffled" : "mixed");
  }
}

/// A SLAM map's float32 records (x y z intensity ...) shuffled: the sorted path reads each
/// point out of file order, including those whose coordinates span two cache lines. Every
/// point is CGAL's answer rounded to float, in its place.
TEST(WarpEquivalence, ShuffledFloatMapMatchesCgalToTheFloat) {
  const Case c = makeCase(2000, 200000);
  const RubberSheet& sheet = *c.result.sheet;
  const pcl::PCLPointCloud2 original = sim::slamCloud(c.drive.map);
  const std::size_t n = static_cast<std::size_t>(original.width) * original.height;
  const std::size_t step = original.point_step;
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::mt19937 rng(5);
  std::shuffle(order.begin(), order.end(), rng);
  pcl::PCLPointCloud2 cloud = original;
  for (std::size_t i = 0; i < n; ++i) {
    std::copy_n(original.data.begin() + order[i] * step, step, cloud.data.begin() + i * step);
  }
  const pcl::PCLPointCloud2 input = cloud;
  const WarpStats stats = warpCloud(cloud, sheet, 2);
  EXPECT_EQ(stats.points, n);
  const XyzLayout l = xyzLayout(cloud, "map");
  std::size_t off = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d want = sheet.transformReference(l.get(input.data.data() + i * step));
    const Eigen::Vector3d got = l.get(cloud.data.data() + i * step);
    for (int a = 0; a < 3; ++a) {
      const float w = static_cast<float>(want(a));
      off += std::abs(static_cast<float>(got(a)) - w) >
             std::nextafter(std::abs(w), 1e30f) - std::abs(w);
    }
    // The other fields travel with their point.
    EXPECT_EQ(0, std::memcmp(cloud.data.data() + i * step + 12, input.data.data() + i * step + 12,
                             step - 12));
  }
  EXPECT_EQ(off, 0u) << "coordinates more than one float step from CGAL's answer";
}

TEST(WarpEquivalence, StreamedFileEqualsTheInMemoryWarp) {
  const Case c = makeCase(200, 300000);
  const std::string dir = ::testing::TempDir() + "stream_" + std::to_string(::getpid());
  fs::create_directories(dir);
  pcl::PCLPointCloud2 cloud = sim::slamCloud(c.drive.map);
  writePcdBinary(dir + "/map.pcd", cloud);
  writePcdBinary(dir + "/truth.pcd", sim::truthCloud(c.drive.map));
  const pcl::PCLPointCloud2 original = cloud;
  warpCloud(cloud, *c.result.sheet, 2);
  for (bool in_place : {true, false}) {
    MapStreamOptions o;
    o.chunk_points = 70001;  // chunks that do not divide the cloud
    o.in_place = in_place;
    o.truth = dir + "/truth.pcd";
    o.T_enu_map = c.result.T_enu_map;
    MapInfo info;
    const std::string out = dir + (in_place ? "/inplace.pcd" : "/pipeline.pcd");
    warpPcdFile(dir + "/map.pcd", out, *c.result.sheet, o, info);
    EXPECT_EQ(info.warp.points, 300000u);
    const pcl::PCLPointCloud2 streamed = readPcd(out);
    ASSERT_EQ(streamed.data.size(), cloud.data.size());
    const XyzLayout a = xyzLayout(cloud, "memory"), b = xyzLayout(streamed, "stream");
    double worst = 0.0;
    for (std::size_t i = 0; i < a.points; ++i) {
      worst = std::max(worst, (a.get(cloud.data.data() + i * a.point_step) -
                               b.get(streamed.data.data() + i * b.point_step))
                                  .norm());
      // every byte beyond x, y, z is the input's
      EXPECT_EQ(std::memcmp(streamed.data.data() + i * b.point_step + 12,
                            original.data.data() + i * a.point_step + 12, a.point_step - 12),
                0);
    }
    EXPECT_LT(worst, 1e-4) << (in_place ? "in place" : "pipeline");  // float32 rounding at most
    const ErrorStats direct = compareClouds(cloud, readPcd(dir + "/truth.pcd"),
                                            [](const Eigen::Vector3d& p) { return p; });
    EXPECT_NEAR(info.truth_rubbersheet.rmse, direct.rmse, 1e-6);
    EXPECT_TRUE(info.has_truth);
    EXPECT_GT(info.truth_aligned.rmse, 1.0);
  }
  fs::remove_all(dir);
}

/// The files of a folder, by name.
std::vector<std::string> filesIn(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::string bytesOf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

/// The tool starts a binary map's copy before the sheet exists: taken over by the warp, the
/// output is the same file byte for byte; a copy of another map is not taken; a copy not taken
/// leaves no file behind.
TEST(WarpEquivalence, APrecopiedBodyGivesTheSameFileAndLeavesNothingWhenNotTaken) {
  const Case c = makeCase(200, 100000);
  const std::string dir = test::tempFolder("precopy").string();
  writePcdBinary(dir + "/map.pcd", sim::slamCloud(c.drive.map));
  fs::copy_file(dir + "/map.pcd", dir + "/other.pcd");
  MapStreamOptions o;
  o.chunk_points = 30001;
  MapInfo info;
  warpPcdFile(dir + "/map.pcd", dir + "/plain.pcd", *c.result.sheet, o, info);
  const auto before = filesIn(dir);
  {
    const auto unused = MapPrecopy::start(dir + "/map.pcd", dir + "/out");
    ASSERT_NE(unused, nullptr);
  }
  EXPECT_EQ(filesIn(dir), before) << "a copy not taken left a file";
  for (const char* copied : {"/map.pcd", "/other.pcd"}) {
    const auto precopy = MapPrecopy::start(dir + copied, dir + "/out");
    ASSERT_NE(precopy, nullptr);
    fs::create_directories(dir + "/out");
    o.precopy = precopy.get();
    MapInfo again;
    warpPcdFile(dir + "/map.pcd", dir + "/out/warped.pcd", *c.result.sheet, o, again);
    EXPECT_EQ(again.warp.points, 100000u);
    EXPECT_EQ(bytesOf(dir + "/out/warped.pcd"), bytesOf(dir + "/plain.pcd")) << copied;
    OutputBody body;
    const bool taken_before = !precopy->takeAs(dir + copied, dir + "/out/again.pcd", body);
    EXPECT_EQ(taken_before, std::string(copied) == "/map.pcd") << copied;
    fs::remove(dir + "/out/again.pcd");
    fs::remove(dir + "/out/warped.pcd");
  }
  EXPECT_TRUE(fs::is_empty(dir + "/out"));
  fs::remove_all(dir);
}

/// An ascii map (written by PCL's own writer) is streamed chunk by chunk too: the result is the
/// in-memory warp of the same file, point for point, every other field kept.
TEST(WarpEquivalence, StreamedAsciiFileEqualsTheInMemoryWarp) {
  const Case c = makeCase(200, 300000);
  const std::string dir = ::testing::TempDir() + "ascii_" + std::to_string(::getpid());
  fs::create_directories(dir);
  ASSERT_EQ(pcl::PCDWriter().writeASCII(dir + "/map.pcd", sim::slamCloud(c.drive.map)), 0);
  pcl::PCLPointCloud2 cloud = readPcd(dir + "/map.pcd");
  const pcl::PCLPointCloud2 original = cloud;
  warpCloud(cloud, *c.result.sheet, 2);
  MapStreamOptions o;
  o.chunk_points = 70001;  // chunks that do not divide the cloud, and several read buffers
  MapInfo info;
  warpPcdFile(dir + "/map.pcd", dir + "/out.pcd", *c.result.sheet, o, info);
  EXPECT_EQ(info.warp.points, 300000u);
  const pcl::PCLPointCloud2 streamed = readPcd(dir + "/out.pcd");
  ASSERT_EQ(streamed.data.size(), cloud.data.size());
  const XyzLayout a = xyzLayout(cloud, "memory"), b = xyzLayout(streamed, "stream");
  double worst = 0.0;
  std::size_t other_bytes_differ = 0;
  for (std::size_t i = 0; i < a.points; ++i) {
    worst = std::max(worst, (a.get(cloud.data.data() + i * a.point_step) -
                             b.get(streamed.data.data() + i * b.point_step))
                                .norm());
    other_bytes_differ +=
        std::memcmp(streamed.data.data() + i * b.point_step + 12,
                    original.data.data() + i * a.point_step + 12, a.point_step - 12) != 0;
  }
  EXPECT_LT(worst, 1e-4);
  EXPECT_EQ(other_bytes_differ, 0u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace flexcloud
