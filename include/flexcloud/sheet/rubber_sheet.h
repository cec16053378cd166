#pragma once
// The 3D rubber sheet: a piecewise-affine map defined by point pairs (source -> target) on the
// Delaunay tetrahedralization of the sources. Inside each tetrahedron the map is the affine
// transform that sends its four source vertices onto their targets, so it is continuous
// across shared faces and exact at every point pair. Outside the convex hull of the sources one
// given affine transform applies.

#include <array>
#include <atomic>
#include <memory>
#include <mutex>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

struct LocatorTet;
class TetLocator;

using Affine34 = Eigen::Matrix<double, 3, 4>;

class RubberSheet {
 public:
  /// Where a point lies: the tetrahedron containing it, or (outside == true) beyond the hull.
  struct Location {
    int tet = -1;
    bool outside = false;
  };

  /// Builds the tetrahedralization of the sources. Points handed to locate()/transform() are
  /// in an input frame that input_to_source maps onto the sources' frame (the rigid alignment:
  /// the triangulation is built where the enclosing cuboid is axis-aligned, so its faces are
  /// exactly planar, while map points are transformed without a detour). `outside` maps input
  /// points beyond the hull. Sources closer than 1 mm to an earlier source are merged into it
  /// (merged()). Throws Error when the counts differ, a point is not finite, or the sources
  /// span no volume.
  RubberSheet(const std::vector<Eigen::Vector3d>& source,
              const std::vector<Eigen::Vector3d>& target, const Affine34& outside,
              const Eigen::Isometry3d& input_to_source = Eigen::Isometry3d::Identity());
  ~RubberSheet();
  RubberSheet(const RubberSheet&) = delete;
  RubberSheet& operator=(const RubberSheet&) = delete;

  /// The same sources with other targets, given as the constructor took them (one per source
  /// handed to it, merged ones included), and another outside transform: the sheet those would
  /// build, sharing this one's tetrahedralization instead of building it again. Throws Error
  /// when the count differs or a target is not finite.
  std::shared_ptr<const RubberSheet> retargeted(const std::vector<Eigen::Vector3d>& target,
                                                const Affine34& outside) const;

  /// Builds the location grid on `threads` threads (0: all cores) unless it exists; locate()
  /// builds it on first use otherwise. `sample`: input points like those to come, so the fine
  /// cells go where they are. Thread-safe.
  void prepare(int threads = 0, const std::vector<Eigen::Vector3d>* sample = nullptr) const;
  bool prepared() const { return prepared_.load(std::memory_order_acquire); }
  /// What the location reads of each tetrahedron (defined inside the core).
  const std::vector<LocatorTet>& locatorTets() const { return geometry_; }
  /// Fast location through the grid; thread-safe.
  Location locate(const Eigen::Vector3d& p) const;
  /// Location by a walk from `hint` (a tetrahedron index, e.g. the previous point's):
  /// fastest for points that follow each other closely, like a trajectory.
  Location locateFrom(const Eigen::Vector3d& p, int hint) const;
  /// The affine transform that applies at a location.
  const Affine34& affineAt(const Location& loc) const {
    return loc.outside ? outside_ : affine_[static_cast<std::size_t>(loc.tet)];
  }
  /// The image of p (fast path).
  Eigen::Vector3d transform(const Eigen::Vector3d& p) const {
    return apply(affineAt(locate(p)), p);
  }
  /// The image of input point p located by CGAL's own point location: the reference path.
  Eigen::Vector3d transformReference(const Eigen::Vector3d& p, bool* outside = nullptr) const;

  static Eigen::Vector3d apply(const Affine34& a, const Eigen::Vector3d& p) {
    return a.leftCols<3>() * p + a.col(3);
  }

  std::size_t numTetrahedra() const { return affine_.size(); }
  /// Vertex indices (into sources()/targets()) of every tetrahedron; sources are in the
  /// source frame, targets in the target frame.
  const std::vector<std::array<int, 4>>& tetrahedra() const { return tet_vertices_; }
  const std::vector<Eigen::Vector3d>& sources() const { return source_; }
  const std::vector<Eigen::Vector3d>& targets() const { return target_; }
  const Affine34& outsideTransform() const { return outside_; }
  std::size_t merged() const { return merged_; }
  /// Tetrahedra too flat to carry their own transform; they use a neighbour's.
  std::size_t degenerate() const { return degenerate_; }
  /// The box of the sources in the input frame: the hull lies within it.
  const Eigen::AlignedBox3d& inputBox() const { return input_box_; }
  /// Level-1 grid cells per axis of the location accelerator (after prepare()).
  Eigen::Vector3i gridSize() const;

 private:
  struct Cgal;

  RubberSheet(const RubberSheet& shape, const std::vector<Eigen::Vector3d>& target,
              const Affine34& outside);
  /// The walk's geometry and each tetrahedron's inverse edge matrix, from the sources.
  void buildGeometry();
  void tetGeometry(std::size_t t, const Eigen::Matrix3d& rot,
                   const Eigen::Isometry3d& source_to_input, double back_shift);
  /// Each tetrahedron's transform, from the targets and the inverses buildGeometry() kept.
  void buildAffine();
  void replaceDegenerate(const std::vector<char>& flat);
  void makeLocator();

  std::vector<Eigen::Vector3d> source_;
  std::vector<Eigen::Vector3d> target_;
  Affine34 outside_;
  std::size_t merged_ = 0;
  std::size_t degenerate_ = 0;
  Eigen::Isometry3d input_to_source_ = Eigen::Isometry3d::Identity();
  Eigen::AlignedBox3d input_box_;
  // Per tetrahedron, in the input frame: what the walk reads, and the transform applied.
  std::vector<LocatorTet> geometry_;
  std::vector<Affine34, Eigen::aligned_allocator<Affine34>> affine_;
  std::vector<std::array<int, 4>> tet_vertices_;
  std::vector<std::size_t> kept_;  ///< of the sources handed in, those not merged
  std::shared_ptr<Cgal> cgal_;     ///< shared by retargeted sheets; its cells numbered once
  std::unique_ptr<TetLocator> locator_;
  mutable std::once_flag grid_once_;
  mutable std::atomic<bool> prepared_{false};
};

}  // namespace flexcloud
