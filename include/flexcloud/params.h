#pragma once
// The one parameter struct of the core. Each field is one row of paramTable() (params.cpp),
// where its default, range, unit and description live; the YAML config, the command line,
// rosparam and dynamic_reconfigure all fill this struct through that table.

#include <limits>
#include <string>
#include <vector>

#include "flexcloud/fusion/fusion.h"
#include "flexcloud/input/gnss.h"
#include "flexcloud/input/interpolation.h"
#include "flexcloud/param_table.h"
#include "flexcloud/sheet/control_points.h"
#include "flexcloud/types.h"

namespace flexcloud {

struct PointSigmaModel;  // flexcloud/uncertainty/point_sigma.h

std::string toString(InterpolationMode mode);
/// Parses "spline" / "nearest"; throws Error naming the value otherwise.
InterpolationMode parseInterpolationMode(const std::string& text);

struct Params {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

  /// Every field at its default from paramTable().
  Params();

  // Datum (NaN: the first valid fix is the datum).
  double datum_lat;
  double datum_lon;
  double datum_alt;
  // GNSS input.
  double default_std_dev;
  double gnss_time_offset;
  double max_gnss_speed;
  // Fusion of SLAM and GNSS.
  bool fusion;
  double fusion_spacing;
  double slam_rotation_noise;
  double slam_translation_noise;
  double slam_drift_noise;
  double slam_scale_noise;
  double gnss_std_floor;
  double outlier_threshold;
  double max_time_offset;
  double max_slam_noise_scale;
  double lever_arm_x;
  double lever_arm_y;
  double lever_arm_z;
  // The SLAM's white jitter from pose to pose, out of the trajectories (jitter_smoothing.h).
  bool smooth_jitter;
  // Keyframe interpolation.
  InterpolationMode interpolation;
  double min_spacing;
  double max_gap;
  // Control points.
  int control_points;
  double stddev_threshold;
  double refine_fraction;
  std::vector<TimeRange> excluded_ranges;
  // Control points beside and above the trajectory.
  double beside_distance;
  double above_height;
  // Rubber sheet: the enclosing cuboid.
  double margin_x;
  double margin_y;
  double margin_z;
  double margin_min;
  // Reporting.
  double max_uncovered_share;
  double max_sigma_h;
  bool accept_degraded;
  // Outputs beside the map.
  bool autoware;
  double tile_size;
  std::string projector;
  bool las;
  std::string map_pose_field;
  bool point_sigma;
  double point_scatter;        // m
  double point_heading_sigma;  // mrad
  double point_tilt_sigma;     // mrad
  bool report_png;
  // Execution.
  int threads;

  /// Every problem with the values (ranges from the table, and the rules that tie fields
  /// together), joined by "; "; empty when the struct is usable.
  std::string validate() const;
  /// Only the rules that tie fields together (the datum is all three or none).
  std::string ruleProblems() const;
  bool hasDatum() const;
};

/// The parameter table of Params.
const ParamTable<Params>& paramTable();

/// Each stage's numbers, from the one parameter struct.
GnssOptions gnssOptions(const Params& p);
FusionOptions fusionOptions(const Params& p);
InterpolationOptions interpolationOptions(const Params& p);
ControlPointOptions controlPointOptions(const Params& p);
PointSigmaModel pointSigmaModel(const Params& p);

}  // namespace flexcloud
