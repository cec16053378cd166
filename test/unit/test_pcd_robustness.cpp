// Malformed PCD files: each is one error naming the file and the problem, never a crash or a
// silently wrong point.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>

#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/warp/cloud_warp.h"
#include "test_util.h"

namespace flexcloud {
namespace {

std::string header(const std::string& fields, const std::string& size, const std::string& type,
                   const std::string& count, int width, int height, const std::string& data,
                   int points = -1) {
  return "# .PCD v0.7\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + size + "\nTYPE " + type +
         "\nCOUNT " + count + "\nWIDTH " + std::to_string(width) + "\nHEIGHT " +
         std::to_string(height) + "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
         std::to_string(points < 0 ? width * height : points) + "\nDATA " + data + "\n";
}

using test::writeTempFile;

std::string errorOf(const std::string& path) {
  return test::errorOf([&] { readPcd(path); });
}

struct Bad {
  const char* name;
  std::string bytes;
  const char* says;
};

TEST(PcdRobustness, MalformedFilesAreOneLineErrors) {
  const std::string xyz = header("x y z", "4 4 4", "F F F", "1 1 1", 2, 1, "ascii");
  const std::vector<Bad> cases = {
      {"empty_file.pcd", "", "not a PCD file"},
      {"text.pcd", "# just a comment\nhello world\n", "not a PCD file"},
      {"no_data.pcd", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\n", "no DATA line"},
      {"counts.pcd", header("x y z", "4 4", "F F F", "1 1 1", 2, 1, "ascii") + "1 2 3\n4 5 6\n",
       "different numbers of fields"},
      {"points.pcd", header("x y z", "4 4 4", "F F F", "1 1 1", 2, 1, "ascii", 5) + "1 2 3\n",
       "is not POINTS"},
      {"type.pcd", header("x y z", "4 4 4", "F F Q", "1 1 1", 1, 1, "ascii") + "1 2 3\n",
       "TYPE 'Q'"},
      {"size.pcd", header("x y z", "4 4 3", "F F F", "1 1 1", 1, 1, "ascii") + "1 2 3\n", "SIZE 3"},
      {"half_float.pcd", header("x y z", "4 4 2", "F F F", "1 1 1", 1, 1, "ascii") + "1 2 3\n",
       "a float of 2 bytes"},
      {"huge.pcd", "FIELDS x\nSIZE 4\nTYPE F\nWIDTH 99999999999999999999\nDATA ascii\n",
       "is not a whole number"},
      {"keyword.pcd", "FIELDS x\nSIZE 4\nTYPE F\nBANANA 3\nWIDTH 1\nDATA ascii\n1\n",
       "unknown PCD header keyword 'BANANA'"},
      {"encoding.pcd", header("x y z", "4 4 4", "F F F", "1 1 1", 1, 1, "zip") + "1 2 3\n",
       "DATA 'zip'"},
      {"short_row.pcd", xyz + "1 2 3\n4 5        \n", ":13: expected 3 values, found 2"},
      {"word.pcd", xyz + "1 2 3\n4 five 6\n", ":13: 'five' is not a value of field y"},
      {"few_rows.pcd", xyz + "1 2 3\n" + std::string(20, ' ') + "\n",
       "holds 1 points, the header 2"},
      {"many_rows.pcd", xyz + "1 2 3\n4 5 6\n7 8 9\n", "more points than the header's 2"},
      {"overflow.pcd",
       header("x y z i", "4 4 4 1", "F F F U", "1 1 1 1", 1, 1, "ascii") + "1 2 3 256\n",
       "'256' is not a value of field i"},
      {"float_range.pcd", header("x y z", "4 4 4", "F F F", "1 1 1", 1, 1, "ascii") + "1 2 1e39\n",
       "'1e39' is not a value of field z"},
      {"binary_short.pcd", header("x y z", "4 4 4", "F F F", "1 1 1", 100, 1, "binary") + "abcdef",
       "the header promises 1200"},
      {"ascii_billions.pcd",
       header("x y z", "4 4 4", "F F F", "1 1 1", 2000000000, 1, "ascii") + "1 2 3\n",
       "cannot hold 2000000000 points"},
      {"compressed_huge.pcd",
       header("x y z", "8 8 8", "F F F", "1 1 1", 2000000000, 1, "binary_compressed") + "12345678",
       "more than 4 GiB unpacked"},
      {"compressed_empty.pcd",
       header("x y z", "4 4 4", "F F F", "1 1 1", 10, 1, "binary_compressed"),
       "compressed body is missing"},
  };
  for (const auto& c : cases) {
    const std::string path = writeTempFile(c.name, c.bytes);
    const std::string e = errorOf(path);
    EXPECT_NE(e.find(c.says), std::string::npos) << c.name << ": " << e;
    EXPECT_NE(e.find(c.name), std::string::npos) << "the error names the file: " << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << "one line: " << e;
  }
}

TEST(PcdRobustness, AsciiKeepsNanPointsAndEveryFieldType) {
  const std::string bytes =
      header("x y z t n big", "4 4 8 1 2 8", "F F F I U I", "1 1 1 1 1 1", 3, 1, "ascii") +
      "1.5 -2 3e2 -128 65535 -9000000000\nnan nan nan 0 0 0\n0 0 0 127 1 9000000000\n";
  const pcl::PCLPointCloud2 c = readPcd(writeTempFile("types.pcd", bytes));
  const XyzLayout l = xyzLayout(c, "types");
  EXPECT_EQ(l.get(c.data.data()), Eigen::Vector3d(1.5, -2.0, 300.0));
  EXPECT_TRUE(l.get(c.data.data() + c.point_step).hasNaN());
  std::int8_t t;
  std::uint16_t n;
  std::int64_t big;
  std::memcpy(&t, c.data.data() + 16, 1);
  std::memcpy(&n, c.data.data() + 17, 2);
  std::memcpy(&big, c.data.data() + 19, 8);
  EXPECT_EQ(t, -128);
  EXPECT_EQ(n, 65535);
  EXPECT_EQ(big, -9000000000LL);
  EXPECT_EQ(c.fields.back().datatype, 9);  // PCLPointField::INT64 from PCL 1.13 on
}

/// The fast number reader takes what the C library's took: a leading '+', hexadecimal floats,
/// infinities, subnormals, CRLF line ends; and refuses what it refused.
TEST(PcdRobustness, AsciiValuesReadAsTheCLibraryReadsThem) {
  const std::string bytes =
      header("x y z t n", "4 4 8 2 2", "F F F I U", "1 1 1 1 1", 2, 1, "ascii") +
      "+1.5 0x1p3 -inf +7 +8\r\n-0.25 1e2 1e-310 -32768 0\n";
  const pcl::PCLPointCloud2 c = readPcd(writeTempFile("c_numbers.pcd", bytes));
  const XyzLayout l = xyzLayout(c, "numbers");
  const Eigen::Vector3d a = l.get(c.data.data()), b = l.get(c.data.data() + c.point_step);
  EXPECT_EQ(a.x(), 1.5);
  EXPECT_EQ(a.y(), 8.0);
  EXPECT_TRUE(std::isinf(a.z()) && a.z() < 0.0);
  EXPECT_EQ(b, Eigen::Vector3d(-0.25, 100.0, 1e-310));
  std::int16_t t;
  std::uint16_t n;
  std::memcpy(&t, c.data.data() + 16, 2);
  std::memcpy(&n, c.data.data() + 18, 2);
  EXPECT_EQ(t, 7);
  EXPECT_EQ(n, 8);
  std::memcpy(&t, c.data.data() + c.point_step + 16, 2);
  EXPECT_EQ(t, -32768);
  for (const char* bad : {"1.5x", "--1", "1..5", "0x", "+-1"}) {
    const std::string path = writeTempFile(
        "c_bad.pcd", header("x", "4", "F", "1", 1, 1, "ascii") + std::string(bad) + "\n");
    EXPECT_NE(errorOf(path).find("is not a value of field x"), std::string::npos) << bad;
  }
  const std::string minus =
      writeTempFile("c_minus.pcd", header("n", "2", "U", "1", 1, 1, "ascii") + std::string("-0\n"));
  EXPECT_NE(errorOf(minus).find("is not a value of field n"), std::string::npos);
}

/// A "line" of megabytes is not a point: the reader says so instead of taking the whole file
/// into memory to find its end.
TEST(PcdRobustness, AnAsciiLineOfMegabytesIsAnError) {
  const std::string path =
      writeTempFile("long_line.pcd", header("x y z", "4 4 4", "F F F", "1 1 1", 2, 1, "ascii") +
                                         "1 2 3\n" + std::string(std::size_t{20} << 20, '7'));
  const std::string e = errorOf(path);
  EXPECT_NE(e.find("long_line.pcd:13: a line longer than 1048576 bytes is not a point"),
            std::string::npos)
      << e;
}

TEST(PcdRobustness, OrganizedAsciiKeepsItsShape) {
  std::string bytes = header("x y z", "4 4 4", "F F F", "1 1 1", 2, 3, "ascii");
  for (int i = 0; i < 6; ++i) bytes += std::to_string(i) + " 0 0\n";
  const pcl::PCLPointCloud2 c = readPcd(writeTempFile("organized.pcd", bytes));
  EXPECT_EQ(c.width, 2u);
  EXPECT_EQ(c.height, 3u);
  const XyzLayout l = xyzLayout(c, "o");
  EXPECT_EQ(l.get(c.data.data() + 5 * c.point_step).x(), 5.0);
}

}  // namespace
}  // namespace flexcloud
