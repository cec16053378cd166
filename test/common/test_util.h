#pragma once
// Helpers shared by the unit, end-to-end and ROS tests: temporary files, simulated drives as
// pipeline input, map error against the simulator's truth, and the message of a failing call.

#include <gtest/gtest.h>
#include <pcl/common/io.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "flexcloud/georeference.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/sim/sim_cloud.h"
#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud::test {

/// A sheet over the box from `lo` to `hi`, with one more point `inside` (the box then splits into
/// tetrahedra around it), that moves every point by `scale` about the origin (1: not at all).
inline std::shared_ptr<RubberSheet> scalingSheet(const Eigen::Vector3d& lo,
                                                 const Eigen::Vector3d& hi,
                                                 const Eigen::Vector3d& inside, double scale) {
  std::vector<Eigen::Vector3d> src, dst;
  for (double x : {lo.x(), hi.x()})
    for (double y : {lo.y(), hi.y()})
      for (double z : {lo.z(), hi.z()}) src.emplace_back(x, y, z);
  src.push_back(inside);
  for (const auto& p : src) dst.push_back(scale * p);
  Affine34 outside = Affine34::Zero();
  outside.leftCols<3>() = scale * Eigen::Matrix3d::Identity();
  return std::make_shared<RubberSheet>(src, dst, outside);
}

/// Writes `bytes` into a file of that name under the test's temporary folder; returns its path.
inline std::string writeTempFile(const std::string& name, const std::string& bytes) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

/// A folder of its own under the temporary folder (per process), created empty.
inline std::filesystem::path tempFolder(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("flexcloud_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// A cloud of width x height zeroed points whose fields (name, PCL datatype) lie one after the
/// other in each point.
inline pcl::PCLPointCloud2 packedCloud(
    const std::vector<std::pair<std::string, std::uint8_t>>& fields, std::uint32_t width,
    std::uint32_t height = 1) {
  pcl::PCLPointCloud2 c;
  std::uint32_t offset = 0;
  for (const auto& [name, type] : fields) {
    c.fields.push_back(pointField(name, offset, type));
    offset += static_cast<std::uint32_t>(pcl::getFieldSize(type));
  }
  c.point_step = offset;
  c.width = width;
  c.height = height;
  c.row_step = offset * width;
  c.data.assign(static_cast<std::size_t>(c.row_step) * height, 0);
  return c;
}

/// The message of the flexcloud::Error that f() throws, or "" when it does not throw.
template <typename F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

/// The simulated drive's fixes and SLAM poses as pipeline input.
inline DriveInput inputOf(const sim::SimDrive& d) { return sim::driveInput(d); }

using sim::atSimDatum;  // parameters at the simulator's datum

/// Warps the drive's map with the result and returns its error against the truth; checks that
/// every point was kept and stayed finite.
inline ErrorStats mapError(const sim::SimDrive& d, const GeoreferenceResult& r,
                           WarpStats* stats = nullptr) {
  pcl::PCLPointCloud2 map = sim::slamCloud(d.map);
  const WarpStats s = warpCloud(map, *r.sheet, 2);
  EXPECT_EQ(s.points, d.map.slam.size());
  EXPECT_EQ(s.non_finite, 0u);
  if (stats) *stats = s;
  return compareClouds(map, sim::truthCloud(d.map), [](const Eigen::Vector3d& x) { return x; });
}

/// What a shell command printed (stdout and stderr) and its exit code (-1: killed).
struct ShellResult {
  int code = -1;
  std::string output;
};

inline ShellResult sh(const std::string& cmd) {
  ShellResult r;
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  while (std::fgets(buf, sizeof(buf), p) != nullptr) r.output += buf;
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace flexcloud::test
