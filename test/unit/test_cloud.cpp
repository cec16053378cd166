#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <random>

#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud {
namespace {

using F = pcl::PCLPointField;

/// A cloud with the fields a real map carries: rgb, intensity, ring, label, a double time,
/// fields before xyz, and xyz of the given type. Organized as rows x cols.
pcl::PCLPointCloud2 richCloud(std::uint32_t rows, std::uint32_t cols, bool double_xyz) {
  pcl::PCLPointCloud2 c;
  const std::uint32_t s = double_xyz ? 8 : 4;
  const std::uint8_t t = double_xyz ? F::FLOAT64 : F::FLOAT32;
  c.fields = {pointField("time", 0, F::FLOAT64),
              pointField("x", 8, t),
              pointField("y", 8 + s, t),
              pointField("z", 8 + 2 * s, t),
              pointField("rgb", 8 + 3 * s, F::FLOAT32),
              pointField("intensity", 12 + 3 * s, F::FLOAT32),
              pointField("ring", 16 + 3 * s, F::UINT16),
              pointField("label", 20 + 3 * s, F::UINT32)};
  c.point_step = 24 + 3 * s;
  c.height = rows;
  c.width = cols;
  c.row_step = c.point_step * cols;
  c.is_dense = 0;
  c.data.resize(static_cast<std::size_t>(c.row_step) * rows);
  std::mt19937 rng(1);
  for (auto& b : c.data) b = static_cast<std::uint8_t>(rng());
  const XyzLayout l = xyzLayout(c, "rich");
  std::uniform_real_distribution<double> u(-100.0, 100.0);
  for (std::size_t i = 0; i < l.points; ++i) {
    std::uint8_t* p = c.data.data() + i * l.point_step;
    l.set(p, Eigen::Vector3d(u(rng), u(rng), u(rng)));
    const double time = 1e9 + static_cast<double>(i);
    std::memcpy(p, &time, 8);
  }
  // Two NaN points that must stay NaN, in place.
  l.set(c.data.data() + 3 * l.point_step, Eigen::Vector3d::Constant(std::nan("")));
  l.set(c.data.data() + 7 * l.point_step, Eigen::Vector3d(1.0, std::nan(""), 2.0));
  return c;
}

RubberSheet shiftSheet(const Eigen::Vector3d& shift) {
  std::vector<Eigen::Vector3d> src, dst;
  for (int c = 0; c < 8; ++c) {
    src.emplace_back(c & 1 ? 200 : -200, c & 2 ? 200 : -200, c & 4 ? 200 : -200);
    dst.push_back(src.back() + shift);
  }
  src.emplace_back(0.0, 0.0, 0.0);
  dst.push_back(shift + Eigen::Vector3d(0.0, 0.0, 1.0));  // a bump in the middle
  Affine34 outside = Affine34::Zero();
  outside.leftCols<3>().setIdentity();
  outside.col(3) = shift;
  return RubberSheet(src, dst, outside);
}

/// Every field but x, y, z holds the same bytes in both clouds (padding between fields is not
/// data and need not survive).
bool sameExceptXyz(const pcl::PCLPointCloud2& a, const pcl::PCLPointCloud2& b) {
  const XyzLayout la = xyzLayout(a, "a"), lb = xyzLayout(b, "b");
  if (la.points != lb.points) return false;
  for (const auto& fa : a.fields) {
    if (fa.name == "x" || fa.name == "y" || fa.name == "z") continue;
    const auto fb = std::find_if(b.fields.begin(), b.fields.end(),
                                 [&](const pcl::PCLPointField& f) { return f.name == fa.name; });
    if (fb == b.fields.end() || fb->datatype != fa.datatype) return false;
    const std::size_t size = pcl::getFieldSize(fa.datatype) * fa.count;
    for (std::size_t i = 0; i < la.points; ++i) {
      if (std::memcmp(a.data.data() + i * la.point_step + fa.offset,
                      b.data.data() + i * lb.point_step + fb->offset, size) != 0) {
        return false;
      }
    }
  }
  return true;
}

TEST(CloudWarp, EveryPointAndFieldSurvivesInOrder) {
  for (bool dbl : {false, true}) {
    const pcl::PCLPointCloud2 in = richCloud(40, 50, dbl);
    pcl::PCLPointCloud2 out = in;
    const RubberSheet sheet = shiftSheet({10.0, -20.0, 5.0});
    const WarpStats s = warpCloud(out, sheet, 2);
    EXPECT_EQ(s.points, 2000u);
    EXPECT_EQ(s.non_finite, 2u);
    EXPECT_EQ(s.outside, 0u);
    EXPECT_EQ(out.width, 50u);
    EXPECT_EQ(out.height, 40u);
    EXPECT_TRUE(sameExceptXyz(in, out));
    const XyzLayout l = xyzLayout(in, "in");
    for (std::size_t i = 0; i < l.points; ++i) {
      const Eigen::Vector3d p = l.get(in.data.data() + i * l.point_step);
      const Eigen::Vector3d q = l.get(out.data.data() + i * l.point_step);
      if (!p.allFinite()) {
        EXPECT_TRUE(q.hasNaN());
        continue;
      }
      const Eigen::Vector3d want = sheet.transformReference(p);
      EXPECT_LT((q - want).norm(), dbl ? 1e-9 : 1e-4);
    }
  }
}

TEST(CloudWarp, PointsBeyondTheCuboidAreMovedRigidlyAndCounted) {
  pcl::PCLPointCloud2 c = richCloud(1, 10, true);
  const XyzLayout l = xyzLayout(c, "c");
  l.set(c.data.data(), Eigen::Vector3d(5000.0, 0.0, 0.0));
  l.set(c.data.data() + l.point_step, Eigen::Vector3d(0.0, 0.0, 0.0005));  // near the origin
  const WarpStats s = warpCloud(c, shiftSheet({1.0, 2.0, 3.0}), 1);
  EXPECT_EQ(s.outside, 1u);
  EXPECT_LT((l.get(c.data.data()) - Eigen::Vector3d(5001.0, 2.0, 3.0)).norm(), 1e-9);
  // Inside the hat of the bump: its apex weight at height h above the centre is 1 - h / 200.
  const double h = 0.0005;
  EXPECT_LT(
      (l.get(c.data.data() + l.point_step) - Eigen::Vector3d(1.0, 2.0, 3.0 + h + 1.0 - h / 200.0))
          .norm(),
      1e-9);
}

TEST(CloudWarp, BadLayoutsAreErrors) {
  pcl::PCLPointCloud2 c = richCloud(1, 10, false);
  c.fields[1].name = "u";  // no x
  EXPECT_THROW(xyzLayout(c, "m"), Error);
  c = richCloud(1, 10, false);
  c.fields[2].datatype = F::INT32;
  EXPECT_THROW(xyzLayout(c, "m"), Error);
  c = richCloud(1, 10, false);
  c.data.resize(c.data.size() - 1);
  EXPECT_THROW(xyzLayout(c, "m"), Error);
}

TEST(PcdIo, AllEncodingsRoundTripWithEveryField) {
  const pcl::PCLPointCloud2 c = richCloud(10, 30, false);
  pcl::PCDWriter w;
  const std::string dir = ::testing::TempDir();
  ASSERT_EQ(
      w.writeASCII(dir + "a.pcd", c, Eigen::Vector4f::Zero(), Eigen::Quaternionf::Identity(), 10),
      0);
  ASSERT_EQ(w.writeBinaryCompressed(dir + "c.pcd", c), 0);
  writePcdBinary(dir + "b.pcd", c);
  for (const char* name : {"b.pcd", "c.pcd"}) {
    const pcl::PCLPointCloud2 r = readPcd(dir + name);
    EXPECT_EQ(r.width * r.height, 300u) << name;
    EXPECT_EQ(r.height, 10u) << name;
    EXPECT_TRUE(sameExceptXyz(c, r)) << name;
  }
  const pcl::PCLPointCloud2 a = readPcd(dir + "a.pcd");  // ascii: values, not bytes
  const XyzLayout la = xyzLayout(a, "a"), lc = xyzLayout(c, "c");
  for (std::size_t i : {0u, 5u, 299u}) {
    EXPECT_LT(
        (la.get(a.data.data() + i * la.point_step) - lc.get(c.data.data() + i * lc.point_step))
            .norm(),
        1e-3);
  }
}

TEST(PcdIo, BadFilesAreOneLineErrors) {
  const std::string dir = ::testing::TempDir();
  std::ofstream(dir + "not.pcd") << "ply\nformat ascii 1.0\n";
  EXPECT_THROW(readPcd(dir + "not.pcd"), Error);
  EXPECT_THROW(readPcd(dir + "missing.pcd"), Error);
  writePcdBinary(dir + "full.pcd", richCloud(1, 1000, false));
  std::ifstream in(dir + "full.pcd", std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(in)), {});
  std::ofstream(dir + "cut.pcd", std::ios::binary) << all.substr(0, all.size() / 2);
  try {
    readPcd(dir + "cut.pcd");
    FAIL() << "a truncated PCD was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.pcd"), std::string::npos);
  }
}

}  // namespace
}  // namespace flexcloud
