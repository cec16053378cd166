#pragma once
// How far each map point may lie from its true place: the sigma of the pose nearest to it (a
// point is placed by the poses it was seen from), grown with its distance from that pose (a
// rotation error of the map about the vehicle moves a far point more: heading horizontally,
// roll and pitch vertically and, for a point above or below the vehicle, horizontally), the
// map's own scatter, and the strain of the sheet where the point lies: where the sheet has to
// stretch or shear the map to carry it onto the result (passes of a drive that disagree, drift
// that bends the map between control points), the map's local shape was wrong there, and how
// wrong grows with the distance from the poses that pin it down.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "flexcloud/sheet/rubber_sheet.h"
#include "flexcloud/types.h"
#include "flexcloud/uncertainty/pose_sigma.h"
#include "flexcloud/warp/cloud_warp.h"

namespace flexcloud {

/// The errors a point adds to its pose's: 1-sigma values. The defaults are those of the LiDAR
/// SLAM of the simulated drives (doc/ACCURACY.md); a map of another quality sets its own
/// (point_scatter, point_heading_sigma, point_tilt_sigma: pointSigmaModel() in params.h).
struct PointSigmaModel {
  double scatter_h = 0.02;  ///< m per horizontal axis: the map's own noise about its poses
  double scatter_v = 0.02;  ///< m
  double heading = 0.0005;  ///< rad: the map's rotation about the vertical near a pose
  double tilt = 0.002;      ///< rad: the map's roll and pitch near a pose
  /// m: the sheet's strain adds about its ratio * (distance from the pose + this), as the
  /// variance 2 ratio^2 (distance^2 + strain_reach^2), never less than the square of that; at
  /// most the change of its edges' lengths (TetStrain)
  double strain_reach = 5.0;
};

/// How far a tetrahedron of the sheet stretches the map: how far its transform is from a
/// rotation (the largest of |s - 1| over its singular values, at most three times its edges'
/// largest relative change of length; 0: rigid), and the largest change of length of its
/// edges, m: a point inside may be moved up to about that.
struct TetStrain {
  float ratio = 0.0F;
  float change = 0.0F;
};

/// The 1-sigma of a map point (ENU, the result's frame), per horizontal axis and vertical, m.
struct PointSigma {
  float h = 0.0F;
  float v = 0.0F;
};

/// The nearest pose of every place in the plan, from a grid over the poses' bounding box (cells
/// of 2 m, or more for a box beyond 1 km a side), and the point sigmas from it.
class PointSigmaField {
 public:
  /// `result` holds the poses in ENU, `sigmas` their sigmas (as many as poses, or empty:
  /// then every point sigma is infinite), `sheet` the sheet that warped the map.
  PointSigmaField(const Trajectory& result, const PoseSigmas& sigmas, const RubberSheet& sheet,
                  const PointSigmaModel& model = {});

  /// The sigma of a point at `enu`, warped by tetrahedron `tet` (-1: beyond the hull). In
  /// floats about the grid's origin (metres to kilometres, to a millimetre): the warp calls it
  /// for every point.
  PointSigma at(const Eigen::Vector3d& enu, int tet) const {
    const float x = static_cast<float>(enu.x() - origin_.x());
    const float y = static_cast<float>(enu.y() - origin_.y());
    const CellPose& c = cells_[cellOf(x, y)];
    const float dx = x - c.x, dy = y - c.y;
    const float dz = static_cast<float>(enu.z() - origin_.z()) - c.z;
    // Squares bounded (a stray point 1e30 m away): every term stays a number, never inf * 0.
    constexpr float kFar2 = 1e30F;
    const float dh2 = std::min(dx * dx + dy * dy, kFar2);
    const float dz2 = std::min(dz * dz, kFar2);
    const TetStrain& s = strain(tet);
    const float bent2 =
        std::min(2.0F * s.ratio * s.ratio * (dh2 + dz2 + reach2_), s.change * s.change);
    const float h2 = c.var_h + scatter_h2_ + heading2_ * dh2 + tilt2_ * dz2 + bent2;
    const float v2 = c.var_v + scatter_v2_ + tilt2_ * dh2 + bent2;
    return {std::sqrt(h2), std::sqrt(v2)};
  }
  /// How far tetrahedron `tet` stretches the map; beyond the hull (-1), how far the outside
  /// transform is from a rotation.
  const TetStrain& strain(int tet) const {
    const auto k = static_cast<std::size_t>(tet);
    return tet >= 0 && k + 1 < strain_.size() ? strain_[k] : strain_.back();
  }
  /// The pose nearest to `enu` in the plan, as the grid knows it (its cell's).
  std::size_t nearestPose(const Eigen::Vector3d& enu) const;

 private:
  /// What a cell knows of its pose: where it is (about the grid's origin) and its variances.
  struct CellPose {
    float x, y, z, var_h, var_v;
  };

  void seed();
  void sweep(bool forward);
  double planDistance2(std::size_t cell, std::int32_t pose) const;
  /// The cell of a place (x, y about the grid's origin); one at the border for a place beyond
  /// it, however far (clamped before the conversion to an integer).
  std::size_t cellOf(float x, float y) const {
    const float fx = std::clamp(x * inv_cell_, 0.0F, static_cast<float>(nx_ - 1));
    const float fy = std::clamp(y * inv_cell_, 0.0F, static_cast<float>(ny_ - 1));
    return static_cast<std::size_t>(fy) * static_cast<std::size_t>(nx_) +
           static_cast<std::size_t>(fx);
  }

  std::vector<Eigen::Vector3d> positions_;
  std::vector<TetStrain> strain_;  ///< per tetrahedron, and last beyond the hull
  float scatter_h2_ = 0, scatter_v2_ = 0, heading2_ = 0, tilt2_ = 0, reach2_ = 0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  double cell_ = 1.0;  ///< m
  float inv_cell_ = 1.0F;
  int nx_ = 1, ny_ = 1;
  std::vector<std::int32_t> nearest_;  ///< per cell, row by row
  std::vector<CellPose> cells_;        ///< the same, ready for at()
};

/// Bytes a point grows by with its sigmas: sigma_h, then sigma_v, float32 each.
constexpr std::size_t kPointSigmaBytes = 8;

/// Copies the n points of `data` (rows of `point_step` bytes) into `out`, each followed by its
/// two floats of `sigmas` (as warpPoints wrote them): rows of point_step + kPointSigmaBytes.
void appendPointSigmas(const std::uint8_t* data, std::size_t point_step, std::size_t n,
                       const float* sigmas, std::uint8_t* out);

/// Copies the n points of `data` (rows of `point_step` bytes) into `out`, each followed by room
/// for its sigmas, NaN until a warp writes them there (SigmaSink into the rows): rows of
/// point_step + kPointSigmaBytes.
void widenPoints(const std::uint8_t* data, std::size_t point_step, std::size_t n,
                 std::uint8_t* out);

}  // namespace flexcloud
