#pragma once
// Cleaning of the SLAM trajectory and arc-length helpers.

#include <optional>
#include <string>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

/// How many poses were dropped or repaired, by reason.
struct PoseCounts {
  std::size_t received = 0;
  std::size_t invalid = 0;     ///< NaN/inf stamp, position or quaternion, or a zero quaternion
  std::size_t duplicate = 0;   ///< same stamp as an earlier pose
  std::size_t normalised = 0;  ///< quaternion was not unit length and was normalised
  std::size_t reordered = 0;   ///< arrived out of stamp order (kept, sorted)
  std::size_t dropped() const { return invalid + duplicate; }
};

/// Sorts by stamp (stable), drops invalid and duplicate-stamp poses, normalises quaternions.
Trajectory preparePoses(const Trajectory& poses, PoseCounts& counts);

/// The poses dropped, in words by reason; empty when none was.
std::string droppedInWords(const PoseCounts& counts);

/// The axes of the poses' body frame as the vehicle moves: `ahead` the mean direction of the
/// motion seen in the body frame, `up` the body axis nearest the map frame's z, `left` = up x
/// ahead (the poses may be of a camera, ahead along its y or z, or of a LiDAR mounted facing
/// back: KITTI's poses move along +y, MulRan's along -x). x, y, z where the poses do not move.
struct BodyAxes {
  Eigen::Vector3d ahead = Eigen::Vector3d::UnitX();
  Eigen::Vector3d left = Eigen::Vector3d::UnitY();
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
};
BodyAxes bodyAxes(const Trajectory& poses);

/// Cumulative path length (m) at each position, starting at 0.
std::vector<double> arcLength(const std::vector<Eigen::Vector3d>& positions);

std::vector<Eigen::Vector3d> positionsOf(const Trajectory& poses);

/// The pose as a transform (body -> its frame), the orientation normalised.
Eigen::Isometry3d isometryOf(const Pose& p);

/// The pose at stamp t, between the two poses around it (position linear, orientation slerp);
/// nothing outside the poses' span. `poses` sorted by stamp.
std::optional<Pose> poseAt(const Trajectory& poses, double t);

/// Distance (m) of each fix from the antenna (`lever_arm` in the body frame) of `track` at the
/// fix's own instant: the track's pose at stamp + offset (offset: the SLAM clock minus the
/// GNSS clock). NaN where that instant lies outside the track.
std::vector<double> deviationsAtFixes(const Trajectory& track, const std::vector<GnssPoint>& fixes,
                                      double offset, const Eigen::Vector3d& lever_arm);

}  // namespace flexcloud
