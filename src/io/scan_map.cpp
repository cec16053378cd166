#include "flexcloud/io/scan_map.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/types.h"
#include "flexcloud/warp/pose_rebuild.h"

namespace flexcloud {

void ScanMap::add(const pcl::PCLPointCloud2& scan, double stamp, const std::string& name) {
  const std::size_t n = static_cast<std::size_t>(scan.width) * scan.height;
  xyzLayout(scan, name);  // x, y, z there, and the data as long as the points
  for (const auto& f : scan.fields) {
    if (f.name == kScanTimeField) throw Error(name + ": a scan holds a field scan_time already");
  }
  if (scans_ == 0) {
    fields_ = scan.fields;
    scan_step_ = scan.point_step;
    step_ = scan.point_step + 8;
  } else if (scan.point_step != scan_step_ || !sameFields(scan.fields, fields_)) {
    throw Error(name + ": a scan's fields differ from those of the first scan");
  }
  const std::size_t at = data_.size();
  data_.resize(at + n * step_);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint8_t* row = data_.data() + at + i * step_;
    std::memcpy(row, scan.data.data() + i * scan_step_, scan_step_);
    std::memcpy(row + scan_step_, &stamp, sizeof(double));
  }
  ++scans_;
}

pcl::PCLPointCloud2 ScanMap::cloud() const {
  pcl::PCLPointCloud2 c;
  c.fields = fields_;
  c.fields.push_back(pointField(kScanTimeField, scan_step_, pcl::PCLPointField::FLOAT64));
  c.point_step = step_;
  c.height = 1;
  c.width = static_cast<std::uint32_t>(points());
  c.row_step = c.point_step * c.width;
  c.is_dense = 0;
  c.data = data_;
  return c;
}

void ScanMap::clear() {
  fields_.clear();
  scan_step_ = step_ = 0;
  data_.clear();
  data_.shrink_to_fit();
  scans_ = 0;
}

std::size_t placeBodyScans(pcl::PCLPointCloud2& cloud, const std::vector<Pose>& slam) {
  const XyzLayout layout = xyzLayout(cloud, "scans");
  const std::optional<PointPoseField> time = pointPoseField(cloud.fields, kScanTimeField, "scans");
  std::size_t beyond = 0;
  double at = std::numeric_limits<double>::quiet_NaN();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // the scan's
  bool far = false;
  for (std::size_t i = 0; i < layout.points; ++i) {
    std::uint8_t* row = cloud.data.data() + i * layout.point_step;
    const double t = time->read(row);
    if (!(t == at)) {  // a scan's points share its stamp: one pose a scan
      at = t;
      const double lo = slam.front().stamp, hi = slam.back().stamp;
      far = !(t >= lo - PoseCorrections::kReach && t <= hi + PoseCorrections::kReach);
      pose = isometryOf(*poseAt(slam, std::clamp(std::isfinite(t) ? t : lo, lo, hi)));
    }
    const Eigen::Vector3d q = layout.get(row);
    if (q.allFinite()) layout.set(row, pose * q);
    beyond += far ? 1 : 0;
  }
  return beyond;
}

bool scansInBodyFrame(const std::string& scans, const std::string& poses, const std::string& body,
                      const std::string& name) {
  if (scans.empty() || poses.empty() || scans == poses) return false;
  if (body.empty() || scans == body) return true;
  throw Error(name + ": the scans are in frame '" + scans + "', neither the poses' ('" + poses +
              "': registered scans) nor their body's ('" + body +
              "': scans as the LiDAR saw them)");
}

}  // namespace flexcloud
