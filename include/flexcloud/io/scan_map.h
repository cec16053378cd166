#pragma once
// A LiDAR SLAM's registered scans (each in the SLAM's map frame, as LIO-SAM and FAST-LIO publish
// them) gathered into one map whose every point carries its scan's stamp: a map whose points
// know their pose, rebuilt rather than warped (pose_rebuild.h).

#include <pcl/PCLPointCloud2.h>

#include <cstdint>
#include <string>
#include <vector>

namespace flexcloud {

/// The field each point of a ScanMap gains: its scan's stamp, float64 s.
constexpr const char* kScanTimeField = "scan_time";

class ScanMap {
 public:
  /// Appends a scan's points (NaN ones too), each with `stamp` (its header's, s). Throws Error
  /// naming `name` where its fields differ from the first scan's, it holds scan_time already, or
  /// its data is shorter than its points.
  void add(const pcl::PCLPointCloud2& scan, double stamp, const std::string& name);
  std::size_t scans() const { return scans_; }
  std::size_t points() const { return step_ == 0 ? 0 : data_.size() / step_; }
  /// The map: every scan's points in the order they came, scan_time after their own fields.
  pcl::PCLPointCloud2 cloud() const;
  void clear();

 private:
  std::vector<pcl::PCLPointField> fields_;  ///< the scans' own
  std::uint32_t scan_step_ = 0;             ///< a scan point's bytes
  std::uint32_t step_ = 0;                  ///< with scan_time
  std::vector<std::uint8_t> data_;
  std::size_t scans_ = 0;
};

}  // namespace flexcloud
