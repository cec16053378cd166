#pragma once
// The node's parameters: the core Params plus what only the ROS node needs, in one table
// (the core rows lifted, then the node's own), read from the parameter server and mapped to and
// from dynamic_reconfigure through that table.

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "flexcloud/GeoreferenceConfig.h"
#include "flexcloud/params.h"

namespace flexcloud {

struct NodeParams {
  /// Every field at its default from nodeParamTable().
  NodeParams();

  Params core;
  std::string enu_frame;
  std::string map_frame;
  std::string odom_type;
  std::string body_frame;
  bool lever_arm_from_tf;
  std::string bag;
  std::string map_file;
  bool georeference_on_bag_end;
  double recompute_delay;
  int max_messages;
  int queue_size;

  /// Every problem, joined by "; "; empty when usable. Includes core.validate().
  std::string validate() const;
};

/// The parameter table of NodeParams: every core row, then the node's own.
const ParamTable<NodeParams>& nodeParamTable();

/// Reads every parameter of the table from the private node handle. Throws Error naming every
/// wrong value, e.g. a string where a number belongs, instead of falling back to the default.
NodeParams loadNodeParams(const ros::NodeHandle& pnh);

/// The names under the private node handle that the table does not know (a misspelled
/// parameter), sorted; the node warns about each, since it would otherwise go unnoticed.
std::vector<std::string> unknownNodeParams(const ros::NodeHandle& pnh);

/// doc/PARAMETERS.md: every row of the table (name, default, range or choices, unit, where it
/// applies, live or not, meaning), as `flexcloud_parameters` prints it.
std::string parametersMarkdown();
/// config/georeference.yaml: every row at its default, with its unit and meaning.
std::string parametersYaml();

/// The live rows of the table into a dynamic_reconfigure config, and back; fromConfig throws
/// Error for a value that is not one of a parameter's choices.
void toConfig(const NodeParams& p, GeoreferenceConfig& config);
NodeParams fromConfig(const GeoreferenceConfig& config, NodeParams p);

/// Checks one value against its row; "" when fine, else the problem naming the parameter.
std::string checkParam(const std::string& name, const ParamValue& value);

}  // namespace flexcloud
