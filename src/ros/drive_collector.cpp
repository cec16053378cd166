#include "flexcloud/ros/drive_collector.h"

#include "flexcloud/ros/conversions.h"

namespace flexcloud {

template <typename T>
void DriveCollector::pushBounded(std::vector<T>& v, T item) {
  if (v.size() >= max_) {
    const std::size_t drop = v.size() / 2;
    v.erase(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(drop));
    evicted_ += drop;
  }
  v.push_back(std::move(item));
}

void DriveCollector::setLimit(std::size_t max_messages) {
  GuardedLock lock(mutex_);
  max_ = max_messages;
}

void DriveCollector::setFrame(const std::string& frame) {
  if (!frame.empty()) frame_ = frame;
}

void DriveCollector::handleFix(const sensor_msgs::NavSatFix& msg) {
  RawFix f = ros_conv::fromNavSatFix(msg);
  GuardedLock lock(mutex_);
  if (!msg.header.frame_id.empty()) fix_frame_ = msg.header.frame_id;
  pushBounded(data_.fixes, f);
}

void DriveCollector::handleOdometry(const nav_msgs::Odometry& msg) {
  Pose p = ros_conv::fromOdometry(msg);
  GuardedLock lock(mutex_);
  if (!msg.child_frame_id.empty()) body_frame_ = msg.child_frame_id;
  setFrame(msg.header.frame_id);
  pushBounded(data_.poses, p);
}

void DriveCollector::handlePose(const geometry_msgs::PoseStamped& msg) {
  Pose p = ros_conv::fromPoseStamped(msg);
  GuardedLock lock(mutex_);
  setFrame(msg.header.frame_id);
  pushBounded(data_.poses, p);
}

void DriveCollector::handlePath(const nav_msgs::Path& msg) {
  Trajectory t = ros_conv::fromPath(msg);
  GuardedLock lock(mutex_);
  setFrame(msg.header.frame_id);
  data_.poses = std::move(t);
}

void DriveCollector::handleScan(const sensor_msgs::PointCloud2& msg, const std::string& topic) {
  pcl::PCLPointCloud2 c;
  ros_conv::fromCloudMsg(msg, c);
  GuardedLock lock(mutex_);
  scans_.add(c, msg.header.stamp.toSec(), topic);
  scan_frame_ = msg.header.frame_id;
}

DriveCollector::Scans DriveCollector::scans() const {
  GuardedLock lock(mutex_);
  if (scans_.scans() == 0) return {};
  return {std::make_shared<pcl::PCLPointCloud2>(scans_.cloud()), scan_frame_, scans_.scans()};
}

DriveInput DriveCollector::snapshot() const {
  GuardedLock lock(mutex_);
  return data_;
}

std::string DriveCollector::fixFrame() const {
  GuardedLock lock(mutex_);
  return fix_frame_;
}

std::string DriveCollector::bodyFrame() const {
  GuardedLock lock(mutex_);
  return body_frame_;
}

std::string DriveCollector::mapFrame() const {
  GuardedLock lock(mutex_);
  return frame_;
}

std::size_t DriveCollector::fixCount() const {
  GuardedLock lock(mutex_);
  return data_.fixes.size();
}

std::size_t DriveCollector::poseCount() const {
  GuardedLock lock(mutex_);
  return data_.poses.size();
}

std::size_t DriveCollector::evicted() const {
  GuardedLock lock(mutex_);
  return evicted_;
}

std::pair<std::size_t, std::size_t> DriveCollector::clear() {
  GuardedLock lock(mutex_);
  const std::pair<std::size_t, std::size_t> cleared{data_.fixes.size(), data_.poses.size()};
  data_ = DriveInput{};
  frame_.clear();
  fix_frame_.clear();
  body_frame_.clear();
  evicted_ = 0;
  scans_.clear();
  scan_frame_.clear();
  return cleared;
}

}  // namespace flexcloud
