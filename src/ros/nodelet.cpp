// The nodelet flexcloud/GeoreferenceNodelet: a shell around GeoreferenceNode. A nodelet cannot
// leave its manager: with a bad parameter the node logs the fatal line and answers every
// service with the reason.
#include <nodelet/nodelet.h>

#include <memory>
#include <pluginlib/class_list_macros.hpp>

#include "flexcloud/ros/georeference_node.h"

namespace flexcloud {

class GeoreferenceNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    node_ = std::make_unique<GeoreferenceNode>(getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<GeoreferenceNode> node_;
};

}  // namespace flexcloud

PLUGINLIB_EXPORT_CLASS(flexcloud::GeoreferenceNodelet, nodelet::Nodelet)
