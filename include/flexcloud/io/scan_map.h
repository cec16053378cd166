#pragma once
// A LiDAR SLAM's registered scans (each in the SLAM's map frame, as LIO-SAM and FAST-LIO publish
// them) gathered into one map whose every point carries its scan's stamp: a map whose points
// know their pose, rebuilt rather than warped (pose_rebuild.h).

#include <pcl/PCLPointCloud2.h>

#include <cstdint>
#include <string>
#include <vector>

namespace flexcloud {

struct Pose;  // flexcloud/types.h

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

/// Scans in the SLAM's body frame (each as the LiDAR saw it, from the pose at its stamp) placed
/// into the SLAM's map frame: every point of `cloud` (a ScanMap's) moved by the pose of `slam`
/// at its scan_time (interpolated; held at the first or last pose up to a second beyond them).
/// Returns how many points lie in scans more than a second beyond the poses: placed by the
/// nearest end pose, and named by the rebuild as naming no pose.
std::size_t placeBodyScans(pcl::PCLPointCloud2& cloud, const std::vector<Pose>& slam);

/// Whether scans in frame `scans` are as the LiDAR saw them, in the odometry's body frame: false
/// where it is `poses` (the poses' frame: registered scans), true where it is `body` (the
/// odometry's child frame, or any other where that is unknown); throws Error naming `name` and
/// the three frames otherwise.
bool scansInBodyFrame(const std::string& scans, const std::string& poses, const std::string& body,
                      const std::string& name);

}  // namespace flexcloud
