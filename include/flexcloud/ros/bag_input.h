#pragma once
// Reading a drive from a rosbag through the same handlers the live node uses.

#include <pcl/PCLPointCloud2.h>

#include <functional>
#include <string>

#include "flexcloud/ros/drive_collector.h"

namespace flexcloud {

/// Topic names; an empty name means: the bag's only topic of a fitting type.
struct BagTopics {
  std::string fix;   ///< sensor_msgs/NavSatFix
  std::string odom;  ///< nav_msgs/Odometry, geometry_msgs/PoseStamped or nav_msgs/Path
  std::string map;   ///< sensor_msgs/PointCloud2 (optional; never auto-picked but as below)
  /// The map topic is taken where the bag has it, else the bag's only PointCloud2 topic, else
  /// none (the node in bag mode: a bag that holds its own map); without it a given map topic
  /// must be in the bag.
  bool map_if_any = false;
  /// A given fix or odom topic that is not in the bag falls back to the bag's only topic of a
  /// fitting type (the node's default names), instead of an error (names the user typed).
  bool fall_back_by_type = false;
  /// The fixes alone (the poses come from elsewhere: a keyframe dump): no odometry topic read.
  bool fixes_only = false;
  /// Registered scans (sensor_msgs/PointCloud2 in the poses' frame) into the collector's scan
  /// map: read where the bag has this topic; a topic the bag lacks is an error unless
  /// scans_if_any (the node's default name).
  std::string scans;
  bool scans_if_any = false;
};

struct BagSummary {
  std::string fix_topic;
  std::string odom_topic;
  std::string odom_type;
  std::string map_topic;
  std::size_t fixes = 0;
  std::size_t poses = 0;  ///< pose messages (a Path counts once)
  std::size_t maps = 0;
  std::string scan_topic;  ///< empty: none read
  std::size_t scans = 0;
};

/// Plays the bag into the collector (and the latest map cloud into *map when map != nullptr and
/// a map topic is given). Throws Error "BAG: ..." for an unreadable or truncated bag, a missing
/// topic or a topic of the wrong type. `progress` (optional) gets the fraction read so far.
BagSummary readBag(const std::string& path, const BagTopics& topics, DriveCollector& collector,
                   pcl::PCLPointCloud2* map = nullptr,
                   const std::function<void(double)>& progress = {});

}  // namespace flexcloud
