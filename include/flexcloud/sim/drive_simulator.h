#pragma once
// A drive simulator that knows the ground truth: a route, the true vehicle poses, GNSS fixes with
// noise, outages and NO_FIX, a SLAM trajectory and map distorted by realistic drift, and the
// true position of every map point. Deterministic from its seed. No ROS in here.

#include <cstdint>
#include <string>
#include <vector>

#include "flexcloud/geo/geodesy.h"
#include "flexcloud/georeference.h"
#include "flexcloud/input/gnss.h"
#include "flexcloud/sim/gnss_errors.h"
#include "flexcloud/sim/slam_errors.h"
#include "flexcloud/types.h"

namespace flexcloud::sim {

struct SimParams {
  std::uint64_t seed = 1;
  /// Loop route whose SLAM is loop-closed (end error spread along the path), or an open
  /// A-to-B route whose drift is left as it accumulated.
  bool loop = true;
  double length = 5000.0;  ///< m, one lap
  /// Laps of the loop driven one after the other.
  int laps = 1;
  /// Close the loop at the end of every lap, as SLAM does when it recognises the place; false:
  /// only at the very end, so the laps stay apart in the map (ghost walls).
  bool close_each_lap = true;
  /// Whether the SLAM closes the loop at all; false: a drive that ends where it began keeps
  /// its drift (odometry without loop closure).
  bool close_loop = true;
  /// The loop as a figure eight that crosses itself on a bridge, the second pass this much
  /// higher than the first (m).
  bool figure_eight = false;
  double bridge_height = 7.0;
  /// Scale of the route's hills; 0: a perfectly level road.
  double elevation = 1.0;
  double speed = 12.0;         ///< m/s
  double stop_duration = 0.0;  ///< s standing still halfway along the route
  /// A speed profile instead of the constant speed (0: none): as fast as max_speed, the curves
  /// (max_lateral_accel), the engine (max_accel) and the brakes (max_brake) allow, from and to
  /// a standstill, as on a race track. m/s and m/s^2.
  double max_speed = 0.0;
  double max_lateral_accel = 15.0;
  double max_accel = 6.0;
  double max_brake = 12.0;
  double odom_rate = 10.0;      ///< Hz
  double gnss_rate = 5.0;       ///< Hz
  double gnss_noise_h = 0.015;  ///< m, 1-sigma, east and north
  double gnss_noise_v = 0.03;   ///< m, 1-sigma, up
  /// Std-devs the receiver reports (covariance of the NavSatFix); <= 0: same as the noise.
  double reported_std_h = 0.0;
  double reported_std_v = 0.0;
  /// Outages: time ranges (s from the start) of degraded GNSS with this noise and reported std.
  std::vector<TimeRange> outages;
  double outage_noise = 1.5;  ///< m, 1-sigma, every axis
  double outage_std = 2.0;    ///< m reported
  /// Time ranges (s from the start) in which the receiver reports NO_FIX.
  std::vector<TimeRange> no_fix;
  /// The receiver's first fix this long after the SLAM's first pose (a cold start, RTK still
  /// converging, a car park) and its last this long before the SLAM's last (s); NO_FIX between.
  double gnss_late_s = 0.0;
  double gnss_early_s = 0.0;
  /// SLAM clock minus GNSS clock (s), as gnss_time_offset: the GNSS stamps lag the SLAM's by
  /// this, and gnss_time_offset = clock_offset undoes it.
  double clock_offset = 0.0;
  /// The errors of urban GNSS beyond the noise above (all off by default).
  GnssErrors gnss_errors;
  /// The GNSS antenna in the vehicle (body) frame, m: the fixes are of the antenna.
  Eigen::Vector3d lever_arm = Eigen::Vector3d::Zero();
  /// SLAM drift: heading and pitch bias (deg per 100 m), scale error (fraction), random walks.
  double heading_bias = 0.1;
  double pitch_bias = 0.04;
  double scale_error = 0.002;
  double rotation_walk = 5e-5;  ///< rad per sqrt(m), each axis
  double position_walk = 1e-3;  ///< m per sqrt(m), each axis
  /// How real SLAM fails beyond that steady drift (all off by default).
  SlamErrors slam_errors;
  /// Map: points on the ground, walls and poles up to 25 m beside the road and 10 m high.
  std::size_t map_points = 200000;
  double sensor_height = 1.8;  ///< m above the road
  Datum datum{48.2620, 11.6670, 480.0};
  double start_stamp = 1700000000.0;  ///< s, SLAM clock at the first pose
};

/// Point cloud data in a neutral form; sim/sim_cloud.h builds PCD clouds from it.
struct SimMap {
  std::vector<Eigen::Vector3d> slam;   ///< SLAM map frame
  std::vector<Eigen::Vector3d> truth;  ///< true ENU of the datum, same order
  std::vector<float> intensity;
  std::vector<std::uint16_t> ring;
  std::vector<std::uint32_t> label;  ///< 1 ground, 2 wall, 3 pole
  std::vector<float> lateral;        ///< m, horizontal distance from the route's centre line
  std::vector<double> time;          ///< s, SLAM clock: the stamp of the scan that saw it
};

struct SimDrive {
  SimParams params;
  Datum datum;
  std::vector<RawFix> fixes;  ///< every message, NO_FIX ones included
  Trajectory slam;            ///< odometry, SLAM map frame, SLAM clock
  Trajectory truth;           ///< true poses in ENU at the same stamps
  SimMap map;
};

/// Simulates a drive. Throws Error for invalid parameters.
SimDrive simulateDrive(const SimParams& params);

/// The drive as the pipeline takes it: every fix message and the SLAM's poses.
DriveInput driveInput(const SimDrive& d);
/// `p` with the simulator's datum, so results compare with its truth directly.
Params atSimDatum(const SimDrive& d, Params p = {});

/// Every problem with the values, joined by "; "; empty when usable.
std::string validate(const SimParams& params);

}  // namespace flexcloud::sim
