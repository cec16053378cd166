#pragma once
// The SLAM's error from pose to pose, beyond the fusion's model of slowly changing drift.

#include <Eigen/Core>
#include <optional>
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
/// `stamps` (s, increasing) are the fixes' own: their gaps and uneven spacing are taken into
/// account (below).
std::vector<Eigen::Vector3d> slamJitter(const std::vector<Eigen::Vector3d>& fixes,
                                        const std::vector<Eigen::Vector3d>& slam,
                                        const std::vector<double>& stamps, int window,
                                        double floor);

/// An upper bound of a track's white noise, horizontal (x and y pooled) and vertical, m: the
/// third divided difference of four consecutive positions at their stamps takes out position,
/// speed and acceleration; scaled by the norm of its coefficients it has the variance of white
/// noise (median |N(0, s^2)| = 0.6745 s) however the positions are spaced in time, so dropped
/// or thinned fixes do not inflate it. What the motion leaves in it only raises the bound. NaN
/// for fewer than 4 positions.
Eigen::Vector2d roughness(const std::vector<Eigen::Vector3d>& track,
                          const std::vector<double>& stamps);

/// The same from the lower quartile of the differences (|N(0, s^2)| has it at 0.3186 s): the
/// white noise of the track's calm part where up to half of it is rough (multipath with
/// jitter), which would raise the median.
Eigen::Vector2d calmRoughness(const std::vector<Eigen::Vector3d>& track,
                              const std::vector<double>& stamps);

/// |third divided difference| of four positions at their stamps, per axis, over the norm of its
/// coefficients (white noise of 1-sigma s gives N(0, s^2) whatever the spacing); none when two
/// stamps coincide.
std::optional<Eigen::Vector3d> thirdDividedDifference(const Eigen::Vector3d x[4],
                                                      const double t[4]);

}  // namespace flexcloud
