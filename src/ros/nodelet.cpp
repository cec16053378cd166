// The nodelet flexcloud/GeoreferenceNodelet: a shell around GeoreferenceNode.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

#include "flexcloud/ros/georeference_node.h"

namespace flexcloud {

class GeoreferenceNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      node_ = std::make_unique<GeoreferenceNode>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      NODELET_FATAL("%s: not started: %s", getName().c_str(), e.what());
    }
  }
  std::unique_ptr<GeoreferenceNode> node_;
};

}  // namespace flexcloud

PLUGINLIB_EXPORT_CLASS(flexcloud::GeoreferenceNodelet, nodelet::Nodelet)
