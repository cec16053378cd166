#pragma once
// The node's parameters: the core Params plus what only the ROS node needs.

#include <ros/node_handle.h>

#include <string>

#include "flexcloud/params.h"

namespace flexcloud {

struct NodeParams {
  Params core;
  /// Frame of the georeferenced outputs.
  std::string enu_frame = "enu";
  /// Frame of the SLAM map and poses; empty: the frame id of the incoming poses.
  std::string map_frame;
  /// Type on the `odom` topic: odometry (nav_msgs/Odometry), pose (geometry_msgs/PoseStamped)
  /// or path (nav_msgs/Path; the latest path replaces all poses).
  std::string odom_type = "odometry";
  /// Read `fix` and `odom` from this bag instead of subscribing.
  std::string bag;
  /// Map to warp; empty: the latest sensor_msgs/PointCloud2 on `map`.
  std::string map_file;
  /// Georeference as soon as the bag has been read.
  bool georeference_on_bag_end = false;
  /// Seconds to wait after a dynamic_reconfigure change before recomputing (the latest wins).
  double recompute_delay = 0.5;
  /// Most fixes and poses kept (oldest half dropped beyond it, and counted).
  int max_messages = 2000000;
  /// Subscriber queue length.
  int queue_size = 5000;

  /// Every problem, joined by "; "; empty when usable. Includes core.validate().
  std::string validate() const;
};

/// Reads every parameter from the private node handle (keys: the field names; the core ones as
/// in config/georeference.yaml). Throws Error naming every wrong value, e.g. a string where a
/// number belongs, instead of falling back to the default.
NodeParams loadNodeParams(const ros::NodeHandle& pnh);

}  // namespace flexcloud
