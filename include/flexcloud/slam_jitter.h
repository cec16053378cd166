#pragma once
// The SLAM's error from pose to pose, beyond the fusion's model of slowly changing drift.

#include <Eigen/Core>
#include <vector>

namespace flexcloud {

/// Per fix, the 1-sigma jitter of the SLAM at its stamp (x = y: horizontal, z: vertical), m.
/// `fixes` and `slam` (the SLAM's antenna position at each fix's stamp) are in ENU and in stamp
/// order. The third differences of the residuals (fix less SLAM) hold neither the vehicle's
/// motion nor the SLAM's drift, only the two noises; those of the fixes alone hold the GNSS's
/// noise (and the motion's jerk, which only raises it). What the residuals hold beyond the
/// fixes, each a robust spread over the `window` fixes on either side, is the SLAM's. Only a
/// clear excess counts (the GNSS's spread is taken 1.5 times and at least `floor`): the two
/// spreads of a smooth SLAM differ by their sampling noise alone.
/// An upper bound of a track's white noise, horizontal (x and y pooled) and vertical, m: the
/// third difference of consecutive positions takes out position, speed and acceleration and has
/// 20 times the variance of white noise (median |N(0, 20 s^2)| = 3.016 s); what the motion
/// leaves in it only raises the bound. NaN for fewer than 4 positions.
Eigen::Vector2d roughness(const std::vector<Eigen::Vector3d>& track);

std::vector<Eigen::Vector3d> slamJitter(const std::vector<Eigen::Vector3d>& fixes,
                                        const std::vector<Eigen::Vector3d>& slam, int window,
                                        double floor);

}  // namespace flexcloud
