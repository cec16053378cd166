#include "flexcloud/sim/sim_cloud.h"

#include <cmath>
#include <cstring>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/io/cloud_layout.h"

namespace flexcloud::sim {
namespace {

template <typename T>
void put(std::uint8_t* dst, T v) {
  std::memcpy(dst, &v, sizeof(T));
}

pcl::PCLPointCloud2 build(const SimMap& map, bool truth, bool time) {
  using F = pcl::PCLPointField;
  const std::uint32_t xyz = truth ? 8 : 4;
  const std::uint32_t base = 3 * xyz;
  pcl::PCLPointCloud2 c;
  c.fields = {pointField("x", 0, truth ? F::FLOAT64 : F::FLOAT32),
              pointField("y", xyz, truth ? F::FLOAT64 : F::FLOAT32),
              pointField("z", 2 * xyz, truth ? F::FLOAT64 : F::FLOAT32),
              pointField("intensity", base, F::FLOAT32),
              pointField("ring", base + 4, F::UINT16),
              pointField("label", base + 8, F::UINT32)};
  c.point_step = base + 12;
  if (time) {
    c.fields.push_back(pointField("time", c.point_step, F::FLOAT64));
    c.point_step += 8;
  }
  c.height = 1;
  c.width = static_cast<std::uint32_t>(map.slam.size());
  c.row_step = c.point_step * c.width;
  c.is_dense = 1;
  c.data.assign(static_cast<std::size_t>(c.row_step), 0);
  const auto& pts = truth ? map.truth : map.slam;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    std::uint8_t* p = c.data.data() + i * c.point_step;
    for (int a = 0; a < 3; ++a) {
      if (truth) {
        put<double>(p + a * xyz, pts[i](a));
      } else {
        put<float>(p + a * xyz, static_cast<float>(pts[i](a)));
      }
    }
    put<float>(p + base, map.intensity[i]);
    put<std::uint16_t>(p + base + 4, map.ring[i]);
    put<std::uint32_t>(p + base + 8, map.label[i]);
    if (time) put<double>(p + base + 12, map.time[i]);
  }
  return c;
}

}  // namespace

namespace {

/// The map's scans that a pose of the drive saw, in the map's order: that pose and its points,
/// in the pose's own frame where `body`, else in the map frame.
std::vector<std::pair<Pose, pcl::PCLPointCloud2>> scans(const SimDrive& d, bool body) {
  std::vector<std::pair<Pose, pcl::PCLPointCloud2>> out;
  const pcl::PCLPointCloud2 all = slamCloud(d.map);
  std::size_t k = 0;  // the pose of the scan at hand (the map is stored scan by scan)
  for (std::size_t i = 0; i < d.map.slam.size();) {
    std::size_t end = i;
    while (end < d.map.slam.size() && d.map.time[end] == d.map.time[i]) ++end;
    while (k < d.slam.size() && d.slam[k].stamp < d.map.time[i] - 1e-6) ++k;
    if (k < d.slam.size() && std::abs(d.slam[k].stamp - d.map.time[i]) < 1e-6) {
      const Eigen::Isometry3d to_body = isometryOf(d.slam[k]).inverse();
      pcl::PCLPointCloud2 c;
      c.fields = all.fields;
      c.point_step = all.point_step;
      c.height = 1;
      c.is_dense = all.is_dense;
      c.width = static_cast<std::uint32_t>(end - i);
      c.row_step = c.point_step * c.width;
      c.data.assign(all.data.begin() + static_cast<std::ptrdiff_t>(i * all.point_step),
                    all.data.begin() + static_cast<std::ptrdiff_t>(end * all.point_step));
      for (std::size_t j = i; body && j < end; ++j) {
        const Eigen::Vector3d p = to_body * d.map.slam[j];
        for (int a = 0; a < 3; ++a) {
          put<float>(c.data.data() + (j - i) * c.point_step + 4 * a, static_cast<float>(p(a)));
        }
      }
      out.emplace_back(d.slam[k], std::move(c));
    }
    i = end;
  }
  return out;
}

}  // namespace

std::vector<std::pair<Pose, pcl::PCLPointCloud2>> keyframeClouds(const SimDrive& d) {
  return scans(d, true);
}

std::vector<std::pair<Pose, pcl::PCLPointCloud2>> registeredScans(const SimDrive& d) {
  return scans(d, false);
}

pcl::PCLPointCloud2 slamCloud(const SimMap& map, bool time) { return build(map, false, time); }
pcl::PCLPointCloud2 truthCloud(const SimMap& map) { return build(map, true, false); }

}  // namespace flexcloud::sim
