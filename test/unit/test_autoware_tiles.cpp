// The Autoware tiles read back with PCL's own reader: every finite point in exactly one tile,
// inside the tile's bounds, with its other fields; the same tiles whatever the chunk size, also
// when a stray point far off spreads a chunk over millions of tiles.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <random>

#include "flexcloud/io/autoware_map.h"
#include "flexcloud/io/pcd_io.h"
#include "test_util.h"

namespace flexcloud {
namespace {

namespace fs = std::filesystem;

constexpr double kTile = 20.0;

/// x y z intensity (float32): 5000 points over 6 x 4 tiles in random order, their index in the
/// intensity; one NaN point and, with `stray`, one point 100 km east and north.
pcl::PCLPointCloud2 testMap(bool stray) {
  std::vector<std::array<float, 4>> pts;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> x(-40.0f, 79.9f), y(-20.0f, 59.9f), z(-2.0f, 8.0f);
  for (int i = 0; i < 5000; ++i) pts.push_back({x(rng), y(rng), z(rng), 0.0f});
  pts.push_back({std::numeric_limits<float>::quiet_NaN(), 1.0f, 1.0f, 0.0f});
  if (stray) pts.push_back({100000.0f, 100000.0f, 3.0f, 0.0f});
  std::shuffle(pts.begin(), pts.end(), rng);
  using F = pcl::PCLPointField;
  pcl::PCLPointCloud2 c = test::packedCloud(
      {{"x", F::FLOAT32}, {"y", F::FLOAT32}, {"z", F::FLOAT32}, {"intensity", F::FLOAT32}},
      static_cast<std::uint32_t>(pts.size()));
  for (std::size_t i = 0; i < pts.size(); ++i) {
    pts[i][3] = static_cast<float>(i);
    std::memcpy(c.data.data() + 16 * i, pts[i].data(), 16);
  }
  return c;
}

/// Index (the intensity) -> the tile's corner, for every point in every tile, read by PCL.
std::map<int, std::pair<double, double>> readTiles(const fs::path& dir) {
  std::map<int, std::pair<double, double>> where;
  for (const auto& entry : fs::directory_iterator(dir / "pointcloud_map")) {
    double tx = 0.0, ty = 0.0;
    EXPECT_EQ(std::sscanf(entry.path().filename().c_str(), "tile_%lf_%lf.pcd", &tx, &ty), 2);
    pcl::PointCloud<pcl::PointXYZI> tile;
    EXPECT_EQ(pcl::PCDReader().read(entry.path().string(), tile), 0) << entry.path();
    for (const auto& p : tile) {
      EXPECT_GE(p.x, tx);
      EXPECT_LT(p.x, tx + kTile);
      EXPECT_GE(p.y, ty);
      EXPECT_LT(p.y, ty + kTile);
      EXPECT_TRUE(where.emplace(static_cast<int>(p.intensity), std::make_pair(tx, ty)).second)
          << "point " << p.intensity << " in two tiles";
    }
  }
  return where;
}

TEST(AutowareTiles, EveryFinitePointInOneTileWhateverTheChunks) {
  for (const bool stray : {false, true}) {
    const pcl::PCLPointCloud2 map = testMap(stray);
    const fs::path dir = test::tempFolder(stray ? "tiles_stray" : "tiles");
    const std::string pcd = (dir / "map.pcd").string();
    writePcdBinary(pcd, map);
    std::map<int, std::pair<double, double>> first;
    for (const std::size_t buffer : {std::size_t{700}, std::size_t{1} << 20}) {
      const fs::path out = dir / ("out_" + std::to_string(buffer));
      AutowareOptions o;
      o.tile_size = kTile;
      o.buffer_points = buffer;
      const AutowareSummary s = writeAutowareMap(pcd, out.string(), Datum{48.0, 11.0, 500.0}, o);
      EXPECT_EQ(s.non_finite, 1u);
      EXPECT_EQ(s.points, map.width - 1u);
      EXPECT_EQ(s.tiles, stray ? 25u : 24u);
      const auto where = readTiles(out);
      EXPECT_EQ(where.size(), map.width - 1u);
      if (first.empty()) {
        first = where;
      } else {
        EXPECT_EQ(where, first) << "buffer " << buffer;
      }
    }
    fs::remove_all(dir);
  }
}

TEST(AutowareTiles, APointBeyondAnyTileIsAnErrorNamingTheMap) {
  pcl::PCLPointCloud2 map = testMap(false);
  const float far = 1e30f;
  std::memcpy(map.data.data() + 16 * 17, &far, 4);
  const fs::path dir = test::tempFolder("tiles_far");
  const std::string pcd = (dir / "map.pcd").string();
  writePcdBinary(pcd, map);
  AutowareOptions o;
  o.tile_size = kTile;
  const std::string error = test::errorOf([&] {
    writeAutowareMap(pcd, (dir / "out").string(), Datum{48.0, 11.0, 500.0}, o);
  });
  EXPECT_NE(error.find(pcd + ": a point at (1.00000001504747e+30"), std::string::npos) << error;
  EXPECT_NE(error.find("beyond the reach of the tiles"), std::string::npos) << error;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace flexcloud
