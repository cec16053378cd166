#pragma once
// What the node shows of a result: the georeferenced map, the TF, the datum, the paths, the
// markers and the ~result message, and their withdrawal on ~reset.

#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <string>
#include <vector>

#include "flexcloud/Georeference.h"
#include "flexcloud/Result.h"
#include "flexcloud/georeference.h"
#include "flexcloud/io/outputs.h"
#include "flexcloud/ros/node_params.h"

namespace flexcloud {

/// Everything one finished run of the node produced.
struct NodeResult {
  GeoreferenceResult result;
  NodeParams params;  ///< the parameters it was made with
  FrameNames frames;
  sensor_msgs::PointCloud2ConstPtr map;  ///< warped, in the ENU frame; null without a map
  MapInfo map_info;
  std::vector<std::string> warnings;
  std::string lever_arm_source;  ///< "tf BODY -> ANTENNA" or "parameters (why)"
  double seconds = 0.0;
};

/// TF `ENU_view` in `enu`: the centre of the corrected trajectory's bounding box, where the rviz
/// configuration's top-down view looks, whatever the drive.
geometry_msgs::TransformStamped viewFrame(const Trajectory& corrected, const std::string& enu,
                                          const ros::Time& stamp);

/// The ~result message: the outcome of the latest run (success, message) and the published
/// result `r` (null: none is published).
flexcloud::Result toResultMsg(const NodeResult* r, bool success, const std::string& message);
/// The service response of a run, from its result message.
flexcloud::Georeference::Response toResponse(const flexcloud::Result& msg);

class ResultPublisher {
 public:
  /// Advertises every latched topic under the private namespace.
  explicit ResultPublisher(ros::NodeHandle& pnh);

  /// Map, TF enu -> map frame, datum, paths and markers of `r`.
  void show(const NodeResult& r);
  /// Empty map and paths, markers cleared: nothing of an earlier result stays on show. (A
  /// static TF cannot be taken back: ~result says has_result false.)
  void withdraw(const FrameNames& frames);
  /// The ~result message.
  void report(const flexcloud::Result& msg);

 private:
  ros::Publisher map_, origin_, path_gnss_, path_slam_, path_aligned_, path_sheet_, control_points_,
      tetrahedra_, deviation_, sigma_, rejected_, result_;
  tf2_ros::StaticTransformBroadcaster tf_;
};

}  // namespace flexcloud
