#include "flexcloud/ros/bag_input.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>

#include <map>
#include <set>

#include "flexcloud/ros/bag_check.h"
#include "flexcloud/ros/conversions.h"

namespace flexcloud {
namespace {

const std::string kFixType = "sensor_msgs/NavSatFix";
const std::string kOdomType = "nav_msgs/Odometry";
const std::string kPoseType = "geometry_msgs/PoseStamped";
const std::string kPathType = "nav_msgs/Path";
const std::string kCloudType = "sensor_msgs/PointCloud2";

std::string absolute(const std::string& topic) {
  return topic.empty() || topic[0] == '/' ? topic : "/" + topic;
}

std::string listing(const std::map<std::string, std::string>& types) {
  std::string s;
  for (const auto& [topic, type] : types) s += (s.empty() ? "" : ", ") + topic + " [" + type + "]";
  return s.empty() ? "none" : s;
}

/// The topic to read for one input: the given one (checked) or the only one of a fitting type.
std::string resolve(const std::string& bag, const std::map<std::string, std::string>& types,
                    const std::string& given, const std::set<std::string>& fitting,
                    const std::string& what, const std::string& option, bool fall_back) {
  std::string expected;
  for (const auto& t : fitting) expected += (expected.empty() ? "" : " or ") + t;
  if (!given.empty() && !(fall_back && types.count(absolute(given)) == 0)) {
    const std::string topic = absolute(given);
    const auto it = types.find(topic);
    if (it == types.end()) {
      throw Error(bag + ": topic " + topic + " is not in the bag (topics: " + listing(types) + ")");
    }
    if (fitting.count(it->second) == 0) {
      throw Error(bag + ": topic " + topic + " holds " + it->second + ", expected " + expected);
    }
    return topic;
  }
  std::vector<std::string> candidates;
  for (const auto& [topic, type] : types) {
    if (fitting.count(type) != 0) candidates.push_back(topic);
  }
  if (candidates.size() == 1) return candidates.front();
  if (candidates.empty()) {
    throw Error(bag + ": no " + what + " topic (" + expected +
                ") in the bag (topics: " + listing(types) + ")");
  }
  std::string names;
  for (const auto& c : candidates) names += (names.empty() ? "" : ", ") + c;
  throw Error(bag + ": several " + what + " topics (" + names + "); choose one with " + option);
}

/// The map topic where the bag holds `given`, else its only PointCloud2 topic, else none.
std::string mapIfAny(const std::map<std::string, std::string>& types, const std::string& given) {
  const auto it = types.find(absolute(given));
  if (it != types.end() && it->second == kCloudType) return it->first;
  std::vector<std::string> clouds;
  for (const auto& [topic, type] : types) {
    if (type == kCloudType) clouds.push_back(topic);
  }
  return clouds.size() == 1 ? clouds.front() : "";
}

/// Checks the vector lengths of a message before the deserializer resizes to them.
bool lengthsFit(const rosbag::MessageInstance& m, bool (*fits)(const std::uint8_t*, std::size_t),
                const std::string& bag) {
  std::vector<std::uint8_t> raw(m.size());
  ros::serialization::OStream stream(raw.data(), static_cast<std::uint32_t>(raw.size()));
  m.write(stream);
  if (!fits(raw.data(), raw.size())) {
    throw Error(bag + ": a " + m.getDataType() + " message on " + m.getTopic() +
                " holds a vector longer than the message (corrupt bag)");
  }
  return true;
}

}  // namespace

BagSummary readBag(const std::string& path, const BagTopics& topics, DriveCollector& collector,
                   pcl::PCLPointCloud2* map, const std::function<void(double)>& progress) {
  BagSummary out;
  checkBagStructure(path);
  try {
    rosbag::Bag bag;
    bag.open(path, rosbag::bagmode::Read);
    std::map<std::string, std::string> types;
    {
      rosbag::View all(bag);
      for (const auto* c : all.getConnections()) types[c->topic] = c->datatype;
    }
    const bool fall_back = topics.fall_back_by_type;
    out.fix_topic =
        resolve(path, types, topics.fix, {kFixType}, "GNSS fix", "--fix-topic", fall_back);
    std::vector<std::string> read{out.fix_topic};
    if (!topics.fixes_only) {
      out.odom_topic = resolve(path, types, topics.odom, {kOdomType, kPoseType, kPathType},
                               "odometry", "--odom-topic", fall_back);
      out.odom_type = types.at(out.odom_topic);
      read.push_back(out.odom_topic);
    }
    if (topics.map_if_any) {
      out.map_topic = mapIfAny(types, topics.map);
    } else if (!topics.map.empty()) {
      out.map_topic = resolve(path, types, topics.map, {kCloudType}, "map", "--map-topic", false);
    }
    if (!topics.scans.empty() &&
        !(topics.scans_if_any && types.count(absolute(topics.scans)) == 0)) {
      out.scan_topic =
          resolve(path, types, topics.scans, {kCloudType}, "scan", "--scan-topic", false);
      if (out.scan_topic == out.map_topic) out.map_topic.clear();  // the scans are the map
      read.push_back(out.scan_topic);
    }
    if (!out.map_topic.empty()) read.push_back(out.map_topic);
    rosbag::View view(bag, rosbag::TopicQuery(read));
    const std::size_t total = view.size();
    std::size_t done = 0;
    for (const rosbag::MessageInstance& m : view) {
      const std::string& topic = m.getTopic();
      if (topic == out.fix_topic) {
        if (auto msg = m.instantiate<sensor_msgs::NavSatFix>()) {
          collector.handleFix(*msg);
          ++out.fixes;
        }
      } else if (topic == out.odom_topic) {
        ++out.poses;
        if (out.odom_type == kOdomType) {
          if (auto msg = m.instantiate<nav_msgs::Odometry>()) collector.handleOdometry(*msg);
        } else if (out.odom_type == kPoseType) {
          if (auto msg = m.instantiate<geometry_msgs::PoseStamped>()) collector.handlePose(*msg);
        } else if (lengthsFit(m, pathLengthsFit, path)) {
          if (auto msg = m.instantiate<nav_msgs::Path>()) collector.handlePath(*msg);
        }
      } else if (topic == out.scan_topic && lengthsFit(m, cloudLengthsFit, path)) {
        if (auto msg = m.instantiate<sensor_msgs::PointCloud2>()) {
          collector.handleScan(*msg, path + ": " + topic);
          ++out.scans;
        }
      } else if (topic == out.map_topic && map != nullptr && lengthsFit(m, cloudLengthsFit, path)) {
        if (auto msg = m.instantiate<sensor_msgs::PointCloud2>()) {
          ros_conv::fromCloudMsg(*msg, *map);
          ++out.maps;
        }
      }
      if (progress && (++done % 20000 == 0 || done == total)) {
        progress(static_cast<double>(done) / static_cast<double>(std::max<std::size_t>(1, total)));
      }
    }
  } catch (const rosbag::BagUnindexedException&) {
    throw Error(path +
                ": the bag has no index (cut short while recording?); run "
                "'rosbag reindex " +
                path + "' first");
  } catch (const rosbag::BagException& e) {
    throw Error(path +
                ": not a readable bag (if it was cut short, 'rosbag reindex' may repair "
                "it): " +
                e.what());
  } catch (const ros::Exception& e) {
    throw Error(path + ": corrupt message data: " + e.what());
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // e.g. a corrupt length field asking for terabytes
    throw Error(path + ": corrupt bag: " + e.what());
  }
  return out;
}

}  // namespace flexcloud
