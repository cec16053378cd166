#include "flexcloud/ros/node_params.h"

#include <cstdio>

#include "flexcloud/io/param_table.h"

namespace flexcloud {
namespace {

/// The value as text for setParam(); throws Error for lists, maps and other non-scalars.
std::string scalarText(const std::string& key, XmlRpc::XmlRpcValue& v) {
  char buf[64];
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeInt:
      return std::to_string(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble:
      std::snprintf(buf, sizeof(buf), "%.17g", static_cast<double>(v));
      return buf;
    case XmlRpc::XmlRpcValue::TypeString:
      return static_cast<std::string>(v);
    default:
      throw Error(key + ": expected a single number or word");
  }
}

double number(const std::string& key, XmlRpc::XmlRpcValue& v) {
  if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) return static_cast<int>(v);
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) return static_cast<double>(v);
  throw Error(key + ": expected a number");
}

template <typename T>
void read(const ros::NodeHandle& pnh, const std::string& key, T& out, std::string& problems) {
  if (!pnh.hasParam(key)) return;
  if (!pnh.getParam(key, out)) {
    problems += (problems.empty() ? "" : "; ") + key + ": wrong type";
  }
}

}  // namespace

std::string NodeParams::validate() const {
  std::string bad = core.validate();
  auto add = [&](bool ok, const std::string& what) {
    if (!ok) bad += (bad.empty() ? "" : "; ") + what;
  };
  add(!enu_frame.empty(), "enu_frame must not be empty");
  add(enu_frame != map_frame, "enu_frame and map_frame must differ");
  add(odom_type == "odometry" || odom_type == "pose" || odom_type == "path",
      "odom_type '" + odom_type + "' is not odometry, pose or path");
  add(recompute_delay >= 0.0 && recompute_delay <= 60.0, "recompute_delay is not in [0, 60] s");
  add(max_messages >= 1000, "max_messages must be at least 1000");
  add(queue_size >= 1 && queue_size <= 1000000, "queue_size is not in [1, 1000000]");
  return bad;
}

NodeParams loadNodeParams(const ros::NodeHandle& pnh) {
  NodeParams p;
  std::string problems;
  for (const auto& ref : paramRefs(p.core)) {
    XmlRpc::XmlRpcValue v;
    if (!pnh.getParam(ref.name, v)) continue;
    try {
      setParam(p.core, ref.name, scalarText(ref.name, v));
    } catch (const Error& e) {
      problems += (problems.empty() ? "" : "; ") + std::string(e.what());
    }
  }
  XmlRpc::XmlRpcValue ranges;
  if (pnh.getParam("excluded_ranges", ranges)) {
    try {
      if (ranges.getType() != XmlRpc::XmlRpcValue::TypeArray) throw Error("excluded_ranges: expected a list");
      for (int i = 0; i < ranges.size(); ++i) {
        XmlRpc::XmlRpcValue& r = ranges[i];
        if (r.getType() != XmlRpc::XmlRpcValue::TypeArray || r.size() != 2) {
          throw Error("excluded_ranges: expected [begin, end] pairs");
        }
        p.core.excluded_ranges.push_back({number("excluded_ranges", r[0]), number("excluded_ranges", r[1])});
      }
    } catch (const Error& e) {
      problems += (problems.empty() ? "" : "; ") + std::string(e.what());
    }
  }
  read(pnh, "enu_frame", p.enu_frame, problems);
  read(pnh, "map_frame", p.map_frame, problems);
  read(pnh, "odom_type", p.odom_type, problems);
  read(pnh, "bag", p.bag, problems);
  read(pnh, "map_file", p.map_file, problems);
  read(pnh, "georeference_on_bag_end", p.georeference_on_bag_end, problems);
  read(pnh, "recompute_delay", p.recompute_delay, problems);
  read(pnh, "max_messages", p.max_messages, problems);
  read(pnh, "queue_size", p.queue_size, problems);
  const std::string invalid = p.validate();
  if (!invalid.empty()) problems += (problems.empty() ? "" : "; ") + invalid;
  if (!problems.empty()) throw Error("parameters of " + pnh.getNamespace() + ": " + problems);
  return p;
}

}  // namespace flexcloud
