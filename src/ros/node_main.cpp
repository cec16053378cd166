// georeference_node: the standalone node, a shell around GeoreferenceNode. Exit 1 when a
// parameter is wrong (the reason is logged).
#include <ros/ros.h>

#include <cstring>
#include <iostream>

#include "flexcloud/io/memory.h"
#include "flexcloud/ros/georeference_node.h"

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "-h") == 0 || std::strcmp(argv[i], "--help") == 0) {
      std::cout << "usage: rosrun flexcloud georeference_node [__name:=NAME] [_PARAM:=VALUE ...]\n"
                   "The flexcloud node (the same as the nodelet flexcloud/GeoreferenceNodelet): "
                   "subscribes to fix and odom (or reads ~bag),\nanswers ~georeference, ~save, "
                   "~reset and ~load_map, publishes ~global_map and ~result. Parameters: "
                   "config/georeference.yaml.\n";
      return 0;
    }
  }
  flexcloud::keepFreedMemory();
  ros::init(argc, argv, "flexcloud");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  flexcloud::GeoreferenceNode node(nh, pnh);
  if (!node.startupError().empty()) return 1;
  ros::spin();
  return 0;
}
