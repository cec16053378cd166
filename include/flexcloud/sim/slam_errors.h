#pragma once
// How real SLAM trajectories fail, for the drive simulator, beyond the steady drift of
// SimParams (a constant heading and pitch rate, a scale error and small random walks). Each is
// written from what LiDAR and visual odometry do on real roads, not from the fusion's model:
// drift whose rate changes with what the sensor sees, height that drifts by itself, a pose graph
// that snaps at loop closures, keyframe trajectories. All are off by default. No ROS in here.

namespace flexcloud::sim {

struct SlamErrors {
  /// The route is cut into stretches of stretch_min_m..stretch_max_m. In a share of them
  /// (`degenerate_share`: open fields, highways, tunnels, where the sensor sees little) the
  /// rotation random walk is stronger by a factor drawn log-uniformly in [1, walk_factor_max].
  /// In every stretch the heading drift rate takes a new value: the SimParams heading_bias plus
  /// a normal change of 1-sigma heading_bias_change (deg per 100 m).
  double degenerate_share = 0.0;
  double walk_factor_max = 1.0;
  double heading_bias_change = 0.0;
  double stretch_min_m = 300.0;
  double stretch_max_m = 1500.0;
  /// Height that drifts without any pitch error (odometry on a flat ground, where nothing
  /// fixes the vertical): the height error grows by a grade error (m per m) that starts at
  /// grade_error and wanders by grade_walk per sqrt(km).
  double grade_error = 0.0;
  double grade_walk = 0.0;
  /// Loop closures on a loop of several laps: where the first lap ends the SLAM recognises the
  /// start, and on every later lap it recognises the first lap's places every
  /// closure_min_m..closure_max_m of path. Each time its pose graph corrects the drift since
  /// the last closure: it spreads the correction over the poses since then, all but a snap of
  /// snap_min_m..snap_max_m (at most the drift) that shows as a jump at the closure.
  bool closures = false;
  double closure_min_m = 200.0;
  double closure_max_m = 600.0;
  double snap_min_m = 0.5;
  double snap_max_m = 3.0;
  /// A pose only every keyframe_min_m..keyframe_max_m of path (drawn per keyframe), as
  /// keyframe-based SLAM writes its trajectory (a stop leaves a gap of its length); 0: every
  /// pose at odom_rate.
  double keyframe_min_m = 0.0;
  double keyframe_max_m = 0.0;
  /// White noise on every pose's position, m per axis: scan matching's error of each scan,
  /// which the next scan does not carry on (KITTI's LiDAR odometry: 1.1-2.0 cm at 10 Hz).
  double pose_jitter = 0.0;
};

}  // namespace flexcloud::sim
