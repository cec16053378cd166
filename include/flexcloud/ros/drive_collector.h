#pragma once
// Collects the drive from ROS messages. Live subscribers and the bag reader call the same
// handlers, so both inputs take one path into the core.

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/PointCloud2.h>

#include <memory>
#include <string>
#include <utility>

#include "flexcloud/georeference.h"
#include "flexcloud/io/scan_map.h"
#include "flexcloud/ros/guarded_mutex.h"

namespace flexcloud {

/// Thread-safe accumulator of fixes and poses.
class DriveCollector {
 public:
  /// Keeps at most this many fixes and poses each (an hour at 100 Hz is 360000); beyond it the
  /// oldest half is dropped and counted, so memory stays bounded on an endless live feed.
  explicit DriveCollector(std::size_t max_messages = 2000000) : max_(max_messages) {}
  void setLimit(std::size_t max_messages);

  void handleFix(const sensor_msgs::NavSatFix& msg);
  void handleOdometry(const nav_msgs::Odometry& msg);
  void handlePose(const geometry_msgs::PoseStamped& msg);
  /// A SLAM back end's optimized path: it replaces every pose collected so far.
  void handlePath(const nav_msgs::Path& msg);
  /// A registered scan (its points in the SLAM's map frame), stamped with its scan's instant:
  /// kept in the scan map (scan_map.h). Throws Error naming `topic` for a scan whose fields
  /// differ from the first one's.
  void handleScan(const sensor_msgs::PointCloud2& msg, const std::string& topic);
  /// The map of the scans collected so far (none: null), a copy of the caller's own, and the
  /// frame they came in.
  struct Scans {
    std::shared_ptr<pcl::PCLPointCloud2> cloud;
    std::string frame;
    std::size_t count = 0;
  };
  Scans scans() const;

  /// A copy of everything collected (the pipeline runs on it while collection goes on).
  DriveInput snapshot() const;
  /// Frame id of the poses (the SLAM map frame), empty until a pose arrived.
  std::string mapFrame() const;
  /// Frame id of the fixes (the GNSS antenna), empty until a fix with one arrived.
  std::string fixFrame() const;
  /// Child frame id of the odometry (the body the poses are of), empty if none was given.
  std::string bodyFrame() const;
  std::size_t fixCount() const;
  std::size_t poseCount() const;
  /// Messages dropped to keep memory bounded.
  std::size_t evicted() const;
  /// Forgets everything collected (the scans too); returns how many fixes and poses that was.
  std::pair<std::size_t, std::size_t> clear();

 private:
  void setFrame(const std::string& frame) FLEXCLOUD_REQUIRES(mutex_);
  template <typename T>
  void pushBounded(std::vector<T>& v, T item) FLEXCLOUD_REQUIRES(mutex_);

  mutable GuardedMutex mutex_;
  DriveInput data_ FLEXCLOUD_GUARDED_BY(mutex_);
  std::string frame_ FLEXCLOUD_GUARDED_BY(mutex_);
  std::string fix_frame_ FLEXCLOUD_GUARDED_BY(mutex_);
  std::string body_frame_ FLEXCLOUD_GUARDED_BY(mutex_);
  std::size_t max_ FLEXCLOUD_GUARDED_BY(mutex_);
  std::size_t evicted_ FLEXCLOUD_GUARDED_BY(mutex_) = 0;
  ScanMap scans_ FLEXCLOUD_GUARDED_BY(mutex_);
  std::string scan_frame_ FLEXCLOUD_GUARDED_BY(mutex_);
};

}  // namespace flexcloud
