#pragma once
// The keyframe graph (fusion.h) holds the SLAM's shape under a slowly changing correction. A
// real SLAM also errs from second to second: it jumps between two scans, creeps while the car
// stands, bends over a few metres where it matched badly. Fixes precise enough to see that
// (own std-dev within max_std) refine the correction fix by fix:
//
//   residual of fix j = c(t_j) + its own noise,  or an outlier of the fix
//   c(t_k) - c(t_j)   = the SLAM's short-term error over the path between, or a jump
//
// per axis, c a random walk over the path (a second of standstill counts as time_metres of
// path) whose intensity q is learned from the drive by maximum likelihood, with two mixture
// components learned alongside (EM): each fix may be an outlier (outlier_prior, a uniform
// density over outlier_box), and each step of c may be a jump of the SLAM (jump_prior, 1-sigma
// jump_sigma). The fixes start with equal say, whatever the keyframe graph called them: a SLAM
// that jumped half a metre for a second made the graph reject a dozen good fixes, and here they
// are taken back. Where the fixes are less precise than max_std (1 Hz urban GNSS, 0.3 m) the
// SLAM's short-term errors lie below their noise and nothing is refined; their verdicts stay
// the graph's.

#include <cstddef>

#include "flexcloud/fusion/fusion.h"

namespace flexcloud {

struct FollowOptions {
  double max_std = 0.1;         ///< m: fixes with a larger horizontal std-dev take no part
  double outlier_prior = 0.05;  ///< prior share of outliers among the fixes
  double outlier_box = 100.0;   ///< m, side of the horizontal box an outlier falls in (40 % up)
  double jump_prior = 1e-3;     ///< prior share of the SLAM's steps that are jumps
  double jump_sigma = 1.0;      ///< m, 1-sigma of a jump per axis
  double bend_prior = 0.01;     ///< prior share of the SLAM's steps that bend
  double bend_ratio = 10.0;     ///< a bend's 1-sigma over the core's
  /// A run of fixes the keyframe graph rejected stays rejected where its median distance
  /// from the graph's trajectory passes this many times the SLAM's short-term error beyond
  /// the fixes' noise (and six of their std-devs): a real LiDAR odometry bends or jumps by
  /// up to 25 times that (KITTI: 0.7 m against 3 cm); the simulated drives' multipath (1-8 m
  /// against 1-2 cm) lies beyond it. At 60, urban_keyframes_1hz seed 2 followed multipath of
  /// a metre (map 0.18 -> 0.28 m) for no gain on a2rl.
  double run_excess = 30.0;
  double time_metres = 1.0;     ///< m of path a second counts for (the SLAM creeps at a stop)
  double start_metres = 100.0;  ///< m of path the correction's first value may have drifted
  double start_q = 1e-4;        ///< m^2 per m, q of the first round
  int rounds = 5;               ///< EM rounds
  std::size_t min_fixes = 10;   ///< fewer precise fixes: nothing is refined
};

/// Refines f.poses by the precise fixes (see above): each pose moves by the correction at its
/// instant (linear between the fixes around it, held beyond the first and last). The fixes that
/// took part get their verdict, weight, residual and error from it; f.follow says what was
/// learned.
void followPreciseGnss(FusionResult& f, const FollowOptions& options);

}  // namespace flexcloud
