#pragma once
// Rebuilding a map whose points know their pose: each point is moved with the rigid correction
// of its own pose (the result's pose times the SLAM's pose inverted), at the point's time or
// scan index, instead of by the rubber sheet. Two passes the SLAM held apart then lie where the
// corrected trajectory puts them; a point far from the road or below it is carried by its
// pose's rotation. Only x, y and z change, in place, as in warpPoints().

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "flexcloud/cancel.h"
#include "flexcloud/types.h"
#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud {

/// The field of each point that names its pose: a time on the trajectory's clock (float64 s) or
/// the index of its pose in the trajectory (an integer).
struct PointPoseField {
  enum class Kind { kTime, kIndex };
  /// How the field is stored (PCD's types).
  enum class Type { kFloat64, kInt8, kUint8, kInt16, kUint16, kInt32, kUint32 };
  std::string name;
  Kind kind = Kind::kTime;
  Type type = Type::kFloat64;
  std::size_t offset = 0;

  /// The field of a point: seconds, or the pose's index as a double.
  double read(const std::uint8_t* point) const;
};

/// The correction of every pose of the trajectory: result_i * slam_i^-1 (map frame -> the
/// result's ENU frame), looked up by index or interpolated in time.
class PoseCorrections {
 public:
  /// `slam` and `result` hold the same poses (same count, same stamps, stamps increasing);
  /// `rigid` moves the points that name no pose (NaN time, an index beyond the trajectory, a
  /// time more than kReach beyond its ends).
  PoseCorrections(const Trajectory& slam, const Trajectory& result, const Eigen::Isometry3d& rigid);

  /// s: a point's time this far before the first pose or after the last is held at that pose's
  /// correction (a scan's points spread over its sweep); beyond, it names no pose.
  static constexpr double kReach = 1.0;

  /// The correction at time t: that of the SLAM's and the result's poses interpolated at t
  /// (positions blended linearly, orientations slerped), taken as the quadratic in time through
  /// its values at the two poses around t and halfway between them (exact at those three
  /// instants; within 0.1 mm of the interpolated poses' for a point 50 m out when the
  /// correction turns a tenth of a degree between poses). `hint` is the last pose interval found
  /// (kept per thread: a scan's points share it). Returns false where t names no pose.
  bool atTime(double t, std::size_t& hint, Eigen::Matrix<double, 3, 4>& out) const;
  /// The pose nearest in time to t, where atTime(t, hint, ...) named one and set `hint`.
  int poseAt(double t, std::size_t hint) const;
  /// The correction of pose i; false where there is no such pose.
  bool atIndex(double i, Eigen::Matrix<double, 3, 4>& out) const;

  const Eigen::Isometry3d& rigid() const { return rigid_; }
  std::size_t size() const { return stamps_.size(); }

  /// Why `values` (a sample of the field over the map) cannot be this trajectory's times or
  /// indices (fewer than 90 % of the finite ones name a pose), or "" where they can.
  std::string mismatch(const PointPoseField& field, const std::vector<double>& values) const;

 private:
  std::vector<double> stamps_;
  std::vector<Eigen::Matrix<double, 3, 4>> corrections_;
  std::vector<Eigen::Matrix<double, 3, 4>> halfway_;  ///< between pose i and i + 1
  /// Time buckets as many as the poses: the first interval of each (the interval of a point in
  /// random order found in a step or two).
  std::vector<std::size_t> bucket_first_;
  double inv_bucket_ = 0.0;
  Eigen::Isometry3d rigid_;
};

/// A map to rebuild: which field names each point's pose, and the poses' corrections.
struct PoseRebuild {
  PointPoseField field;
  const PoseCorrections* corrections = nullptr;
};

/// The values of `field` of at most `max` points spread evenly over `points` rows of `step`
/// bytes at `data` (for PoseCorrections::mismatch()).
std::vector<double> fieldValues(const std::uint8_t* data, std::size_t step, std::size_t points,
                                const PointPoseField& field, std::size_t max = 1 << 18);

/// Moves the xyz of every point of a raw buffer of the given layout with its own pose's
/// correction, on `threads` threads (0: all cores). Points that name no pose are moved by the
/// rigid transform and counted as `outside`; NaN points stay as they are (`non_finite`). With
/// `sigmas` set, each point's sigmas are those of a point moved rigidly with its own pose (the
/// nearest in time; PointSigmaField::ofPose()). Throws Error("NAME: rebuild: cancelled") once
/// cancelled.
WarpStats rebuildPoints(std::uint8_t* data, const XyzLayout& layout, const PoseRebuild& rebuild,
                        int threads, const std::string& name = "map",
                        const CancelToken& cancel = neverCancelled(), const SigmaSink& sigmas = {});

/// Moves the n points of one keyframe's cloud (a SLAM's keyframe dump), given in the keyframe's
/// own frame: each placed by `pose` (the keyframe's pose in the SLAM's map frame) and moved with
/// the correction at `stamp` (rigidly where that names no pose: every point counted as
/// `outside`), on one thread. The sample holds a few of its points in the map frame. With
/// `sigmas` set, as rebuildPoints().
WarpStats rebuildKeyframe(std::uint8_t* data, const XyzLayout& layout,
                          const Eigen::Isometry3d& pose, double stamp,
                          const PoseCorrections& corrections, const SigmaSink& sigmas = {});

}  // namespace flexcloud
