// georeference_node: the standalone node, a shell around GeoreferenceNode.
#include <ros/ros.h>

#include "flexcloud/ros/georeference_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "flexcloud");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  try {
    flexcloud::GeoreferenceNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("%s: not started: %s", pnh.getNamespace().c_str(), e.what());
    return 1;
  }
  return 0;
}
