#pragma once
// The 3D rubber sheet: a piecewise-affine map defined by point pairs (source -> target) on the
// Delaunay tetrahedralization of the sources. Inside each tetrahedron the map is the affine
// transform that sends its four source vertices onto their targets, so it is continuous
// across shared faces and exact at every point pair. Outside the convex hull of the sources one
// given affine transform applies.

#include <array>
#include <memory>
#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

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
              const Eigen::Isometry3d& input_to_source = Eigen::Isometry3d::Identity(),
              bool with_grid = true);
  ~RubberSheet();
  RubberSheet(const RubberSheet&) = delete;
  RubberSheet& operator=(const RubberSheet&) = delete;

  /// Fast location (grid start cell + walk; a walk from tetrahedron 0 without the grid);
  /// thread-safe.
  Location locate(const Eigen::Vector3d& p) const;
  /// Location by a walk from `hint` (a tetrahedron index, e.g. the previous point's):
  /// fastest for points that follow each other closely, like a trajectory.
  Location locateFrom(const Eigen::Vector3d& p, int hint) const;
  /// The affine transform that applies at a location.
  const Affine34& affineAt(const Location& loc) const {
    return loc.outside ? outside_ : tets_[static_cast<std::size_t>(loc.tet)].affine;
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

  std::size_t numTetrahedra() const { return tets_.size(); }
  /// Vertex indices (into sources()/targets()) of every tetrahedron; sources are in the
  /// source frame, targets in the target frame.
  const std::vector<std::array<int, 4>>& tetrahedra() const { return tet_vertices_; }
  const std::vector<Eigen::Vector3d>& sources() const { return source_; }
  const std::vector<Eigen::Vector3d>& targets() const { return target_; }
  const Affine34& outsideTransform() const { return outside_; }
  std::size_t merged() const { return merged_; }
  /// Tetrahedra too flat to carry their own transform; they use a neighbour's.
  std::size_t degenerate() const { return degenerate_; }
  /// Grid cells per axis of the location accelerator.
  Eigen::Vector3i gridSize() const { return grid_n_; }

 private:
  // All three members below are in the input frame.
  struct Tet {
    Eigen::Matrix3d bary;  ///< inverse of [v1-v0 v2-v0 v3-v0]: barycentric coordinates
    Eigen::Vector3d v0;
    Affine34 affine;       ///< input frame -> target frame
    std::array<int, 4> neighbour;  ///< across the face opposite vertex i; -1 beyond the hull
  };
  struct Cgal;

  Location walk(const Eigen::Vector3d& p, int start) const;
  Location bruteForce(const Eigen::Vector3d& p) const;
  void buildTets(const Eigen::Isometry3d& input_to_source);
  void replaceDegenerate(const std::vector<bool>& flat);
  void buildGrid(const Eigen::Isometry3d& input_to_source);

  std::vector<Eigen::Vector3d> source_;
  std::vector<Eigen::Vector3d> target_;
  Affine34 outside_;
  std::size_t merged_ = 0;
  std::size_t degenerate_ = 0;
  Eigen::Isometry3d input_to_source_ = Eigen::Isometry3d::Identity();
  std::vector<Tet> tets_;
  std::vector<std::array<int, 4>> tet_vertices_;
  std::unique_ptr<Cgal> cgal_;

  // Location grid over the bounding box of the sources. cell_ >= 0: the whole cell lies in
  // that tetrahedron; cell_ < 0: -(start + 1), a tetrahedron to walk from.
  Eigen::Vector3d grid_lo_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d grid_hi_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d grid_scale_ = Eigen::Vector3d::Zero();
  Eigen::Vector3i grid_n_ = Eigen::Vector3i::Zero();
  std::vector<int> cell_;
};

}  // namespace flexcloud
