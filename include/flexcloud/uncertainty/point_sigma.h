#pragma once
// How far each map point may lie from its true place: the sigma of the pose nearest to it (a
// point is placed by the poses it was seen from; in a map rebuilt from its points' poses, its
// own pose's), grown with its distance from that pose (a
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
  double heading = 0.004;   ///< rad: the map's rotation about the vertical near a pose
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

  /// What a point's sigma is made of: its nearest pose's variances with the map's scatter, its
  /// squared distances from that pose (horizontal, vertical) and its tetrahedron's strain
  /// (2 ratio^2 and the square of its edges' largest change of length).
  struct Terms {
    float var_h, var_v, dh2, dz2, bend2, cap2;
  };

  /// The sigma of a point at `enu`, warped by tetrahedron `tet` (-1: beyond the hull).
  PointSigma at(const Eigen::Vector3d& enu, int tet) const {
    const Terms t = terms(local(enu), tet);
    PointSigma s;
    combine(t.var_h, t.var_v, t.dh2, t.dz2, t.bend2, t.cap2, s.h, s.v);
    return s;
  }
  /// The sigma of a point at `enu` moved rigidly with pose `pose` (a map rebuilt from its
  /// points' poses, pose_rebuild.h): that pose's, grown with the point's distance from it, no
  /// strain of the sheet; a pose beyond the trajectory's (-1: the point names none) stands for
  /// the pose nearest in plan.
  PointSigma ofPose(const Eigen::Vector3d& enu, int pose) const {
    PointSigma s;
    const Eigen::Vector3f p = local(enu);
    sigmasOfPoses(1, &p.x(), &p.y(), &p.z(), &pose, &s.h, &s.v);
    return s;
  }
  /// Stands for a point that names no pose.
  static constexpr int kNoPose = -1;
  /// A place about the grid's origin, in floats (metres to kilometres, to a millimetre).
  Eigen::Vector3f local(const Eigen::Vector3d& enu) const { return (enu - origin_).cast<float>(); }
  /// The terms of the sigma of a point at `p` about the grid's origin (local()), warped by
  /// tetrahedron `tet`, looked up.
  Terms terms(const Eigen::Vector3f& p, int tet) const {
    const CellPose& c = cells_[cellOf(p.x(), p.y())];
    const float dx = p.x() - c.x, dy = p.y() - c.y, dz = p.z() - c.z;
    const TetTerms& s = tet_terms_[termsIndex(tet)];
    return {c.var_h, c.var_v, bounded(dx * dx + dy * dy), bounded(dz * dz), s.bend2, s.cap2};
  }
  /// A point's sigmas from its terms: the arithmetic alone, which PointSigmaBatch runs for many
  /// points at once.
  void combine(float var_h, float var_v, float dh2, float dz2, float bend2, float cap2, float& h,
               float& v) const {
    const float bent2 = std::min(bend2 * (dh2 + dz2 + reach2_), cap2);
    h = std::sqrt(var_h + heading2_ * dh2 + tilt2_ * dz2 + bent2);
    v = std::sqrt(var_v + tilt2_ * dh2 + bent2);
  }
  /// The most points sigmas() takes at once.
  static constexpr std::size_t kBatch = 256;
  /// The sigmas of n <= kBatch points at (x, y, z) about the grid's origin (local()), warped by
  /// tetrahedra `tet`, into h and v: as at() gives them, with the arithmetic in vector lanes
  /// (only the lookups go point by point).
  void sigmas(std::size_t n, const float* x, const float* y, const float* z, const int* tet,
              float* __restrict h, float* __restrict v) const;
  /// The same for n <= kBatch points moved rigidly with poses `pose` (ofPose()).
  void sigmasOfPoses(std::size_t n, const float* x, const float* y, const float* z, const int* pose,
                     float* __restrict h, float* __restrict v) const;
  /// How far tetrahedron `tet` stretches the map; beyond the hull (-1), how far the outside
  /// transform is from a rotation.
  const TetStrain& strain(int tet) const {
    const auto k = static_cast<std::size_t>(tet);
    return tet >= 0 && k + 1 < strain_.size() ? strain_[k] : strain_.back();
  }
  /// The pose nearest to `enu` in the plan, as the grid knows it (its cell's).
  std::size_t nearestPose(const Eigen::Vector3d& enu) const;

 private:
  /// What a cell knows of its pose: where it is (about the grid's origin) and its variances
  /// with the map's scatter.
  struct CellPose {
    float x, y, z, var_h, var_v;
  };

  void seed();
  void sweep(bool forward);
  double planDistance2(std::size_t cell, std::int32_t pose) const;
  /// The cell of a place (x, y about the grid's origin); one at the border for a place beyond
  /// it, however far (clamped before the conversion to an integer).
  /// Written as selects, which compile to min/max instructions (std::clamp took branches, which
  /// a map's scattered points mispredict); a NaN place goes to cell 0.
  std::size_t cellOf(float x, float y) const {
    const float fx = within(x * inv_cell_, last_x_), fy = within(y * inv_cell_, last_y_);
    // Through int: a float's conversion to an unsigned 64-bit integer takes a branch.
    return static_cast<std::size_t>(static_cast<int>(fy) * nx_ + static_cast<int>(fx));
  }
  /// v within [0, hi]; a NaN to 0.
  static float within(float v, float hi) {
    const float lo = v > 0.0F ? v : 0.0F;
    return lo < hi ? lo : hi;
  }
  /// A square bounded (a stray point 1e30 m away): every term stays a number, never inf * 0.
  static float bounded(float v2) {
    constexpr float kFar2 = 1e30F;
    return v2 < kFar2 ? v2 : kFar2;
  }
  /// Where tetrahedron `tet`'s terms are kept: at tet + 1, and 0 beyond the hull (-1) or for a
  /// tetrahedron the sheet does not have.
  std::size_t termsIndex(int tet) const {
    const auto k = static_cast<std::size_t>(static_cast<std::int64_t>(tet) + 1);
    return k < tet_terms_.size() ? k : 0;
  }

  std::vector<Eigen::Vector3d> positions_;
  /// A tetrahedron's strain as at() takes it: 2 ratio^2 and change^2.
  struct TetTerms {
    float bend2, cap2;
  };

  std::vector<TetStrain> strain_;    ///< per tetrahedron, and last beyond the hull
  std::vector<TetTerms> tet_terms_;  ///< the same, beyond the hull first (at tet + 1)
  float heading2_ = 0, tilt2_ = 0, reach2_ = 0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  double cell_ = 1.0;  ///< m
  float inv_cell_ = 1.0F;
  int nx_ = 1, ny_ = 1;
  float last_x_ = 0.0F, last_y_ = 0.0F;  ///< the last cell's index a side, as floats
  std::vector<std::int32_t> nearest_;    ///< per cell, row by row
  std::vector<CellPose> cells_;          ///< the same, ready for at()
  std::vector<CellPose> poses_;          ///< per pose, as a cell knows it
};

/// The sigmas of points warped one at a time, computed a batch at a time: the warp hands each
/// point's place and tetrahedron over and goes on, and the lookups and square roots of a
/// batch's points run together, apart from the warp's chain of dependent steps (interleaved
/// with it, they made the warp 1.4x as slow, here about 1.2x; doc/BENCHMARKS.md).
class PointSigmaBatch {
 public:
  /// What add() is told of each point: the tetrahedron that warped it, or the pose it was
  /// moved with (PointSigmaField::ofPose()).
  enum class Moved { kBySheet, kWithPose };
  /// Writes where `sink` says (its field must be set).
  explicit PointSigmaBatch(const SigmaSink& sink, Moved moved = Moved::kBySheet)
      : sink_(sink), moved_(moved) {}
  PointSigmaBatch(const PointSigmaBatch&) = delete;
  PointSigmaBatch& operator=(const PointSigmaBatch&) = delete;
  ~PointSigmaBatch() { flush(); }

  /// Point `index`, now at `enu`, warped by tetrahedron `by` (or moved with pose `by`, as
  /// constructed): its sigmas are written by the next flush() at the latest.
  void add(const Eigen::Vector3d& enu, int by, std::size_t index) {
    const Eigen::Vector3f p = sink_.field->local(enu);
    x_[n_] = p.x(), y_[n_] = p.y(), z_[n_] = p.z();
    by_[n_] = by;
    index_[n_] = index;
    if (++n_ == kSize) flush();
  }
  /// Writes the sigmas of every point added since the last flush.
  void flush();

 private:
  static constexpr std::size_t kSize = PointSigmaField::kBatch;
  SigmaSink sink_;
  Moved moved_;
  std::size_t n_ = 0;
  float x_[kSize], y_[kSize], z_[kSize];  // about the field's origin
  int by_[kSize];                         // tetrahedra or poses
  std::size_t index_[kSize];
};

/// Bytes a point grows by with its sigmas: sigma_h, then sigma_v, float32 each.
constexpr std::size_t kPointSigmaBytes = 8;

/// Copies the n points of `data` (rows of `point_step` bytes) into `out`, each followed by room
/// for its sigmas, NaN until a warp writes them there (SigmaSink into the rows): rows of
/// point_step + kPointSigmaBytes.
void widenPoints(const std::uint8_t* data, std::size_t point_step, std::size_t n,
                 std::uint8_t* out);

}  // namespace flexcloud
