#pragma once
// The one parameter struct of the core. The YAML config, the command line, rosparam and
// dynamic_reconfigure all fill this struct; the key of each field is its name.

#include <limits>
#include <string>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

enum class InterpolationMode { kSpline, kNearest };

std::string toString(InterpolationMode mode);
/// Parses "spline" / "nearest"; throws Error naming the value otherwise.
InterpolationMode parseInterpolationMode(const std::string& text);

struct Params {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

  // --- Datum -----------------------------------------------------------------------------
  /// Latitude (deg) of the ENU datum; NaN: the first valid fix is the datum.
  double datum_lat = kNaN;
  /// Longitude (deg) of the ENU datum; NaN with datum_lat.
  double datum_lon = kNaN;
  /// Ellipsoidal altitude (m) of the ENU datum; NaN with datum_lat.
  double datum_alt = kNaN;

  // --- GNSS input --------------------------------------------------------------------------
  /// 1-sigma std-dev (m) given to fixes whose covariance is unknown; 0 drops such fixes.
  double default_std_dev = 0.0;
  /// Seconds added to every GNSS stamp before matching (receiver clock offset to the SLAM clock).
  double gnss_time_offset = 0.0;
  /// A step between fixes that would need more than this speed (m/s) is a position jump of the
  /// receiver; the fixes that jumped away (until it jumps back) are dropped.
  double max_gnss_speed = 150.0;

  // --- Keyframe interpolation -------------------------------------------------------------
  InterpolationMode interpolation = InterpolationMode::kSpline;
  /// Minimum distance (m) between the GNSS points that support the cubic spline.
  double min_spacing = 1.0;
  /// Longest GNSS gap (s) that is interpolated across; poses inside longer gaps get no GNSS.
  double max_gap = 1.0;

  // --- Control points ---------------------------------------------------------------------
  /// Number of control points spread by arc length along the trajectory.
  int control_points = 200;
  /// Largest GNSS 3D std-dev (m) a control point may have; worse candidates are replaced.
  double stddev_threshold = 0.1;
  /// Share of the control points placed by error-driven refinement: round by round, each
  /// stretch between neighbouring control points gets one more at the usable pose whose
  /// rubber-sheeted position still deviates most from the GNSS. The rest are spread evenly by
  /// arc length first. 0 gives the even spread of the published method.
  double refine_fraction = 0.75;
  /// Time ranges (s, SLAM clock) from which no control point is taken.
  std::vector<TimeRange> excluded_ranges;

  // --- Rubber sheet -----------------------------------------------------------------------
  /// Cuboid margin beyond the trajectory extent, as a fraction of the extent per axis.
  double margin_x = 0.1;
  double margin_y = 0.1;
  double margin_z = 10.0;
  /// Smallest cuboid margin (m) on every axis, so a flat or straight trajectory still gets a
  /// solid cuboid.
  double margin_min = 20.0;

  // --- Execution --------------------------------------------------------------------------
  /// Threads for the map warp; 0: all cores.
  int threads = 0;

  /// Every problem with the values, joined by "; "; empty when the struct is usable.
  std::string validate() const;
  bool hasDatum() const;
};

}  // namespace flexcloud
