// Fuzz target: the bag input path (rosbag, the topic checks, the message handlers) on any bytes.
#include <cstdint>

#include "flexcloud/ros/bag_input.h"
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace flexcloud;
  const fuzz::MemFile file(data, size);
  try {
    DriveCollector collector;
    pcl::PCLPointCloud2 map;
    readBag(file.path(), BagTopics{}, collector, &map);
    if (collector.poseCount() > 0 && collector.fixCount() > 0) {
      Params p;
      p.control_points = 8;
      georeference(collector.snapshot(), p);
    }
  } catch (const Error&) {
  }
  return 0;
}
