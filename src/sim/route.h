#pragma once
// The simulator's route and how the vehicle moves along it. Private to the simulator.

#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "flexcloud/sim/drive_simulator.h"

namespace flexcloud::sim {

/// The route as a dense polyline with cumulative arc length.
class Route {
 public:
  explicit Route(std::vector<Eigen::Vector3d> pts);
  double length() const { return s_.back(); }

  /// True pose at arc length s: x forward along the road, z up (no roll).
  Eigen::Isometry3d poseAt(double s) const;

  /// Horizontal curvature (1/m) at arc length s, over the same few metres as the heading.
  double curvatureAt(double s) const;

 private:
  std::size_t segmentAt(double s) const;
  Eigen::Vector3d tangentAt(std::size_t i) const;

  std::vector<Eigen::Vector3d> pts_;
  std::vector<double> s_;
};

/// The route of the parameters: a loop (or a figure eight crossing itself on a bridge) or an
/// open A-to-B road, with hills, p.length long.
Route makeRoute(const SimParams& p, std::mt19937_64& rng);

/// Arc length driven as a function of time: at a constant speed, or (p.max_speed > 0) as fast as
/// the curves, the acceleration and the brakes allow; either with the optional stop halfway.
class Motion {
 public:
  /// `length`: the whole drive (all laps); `lap`: one lap of `route`.
  Motion(const SimParams& p, const Route& route, double length);
  double duration() const { return duration_; }
  /// Arc length at time t (s from the start).
  double arcAt(double t) const;

 private:
  const SimParams& p_;
  double length_;
  double duration_ = 0.0;
  std::vector<double> t_;       ///< with a speed profile: time at each metre of the drive
  std::size_t stop_metre_ = 0;  ///< with a speed profile: where the stop is
};

}  // namespace flexcloud::sim
