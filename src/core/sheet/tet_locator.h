#pragma once
// Point location in a tetrahedralization without scanning the tetrahedra, from a two-level grid.
// Level 1 covers the bounding box; a level-1 cell inside one tetrahedron answers at once, a mixed
// one holds a block of sub-cells, as fine as a memory budget allows where the points to locate
// are. A sub-cell inside one tetrahedron answers at once too; a mixed sub-cell lists the
// tetrahedra at its corners, which are tested directly (independent loads, unlike the steps of a
// walk), and a visibility walk over neighbours from there settles the rare rest. Thread-safe once
// built; private to the core.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <vector>

namespace flexcloud {

/// What the walk needs of a tetrahedron, in two cache lines of its own (the vertices, needed
/// only by the exact test, are kept apart): a test of a guess and a walk's step read 2 lines
/// per tetrahedron, where 136 bytes at any offset read 3 or 4.
struct alignas(64) LocatorTet {
  Eigen::Matrix3d bary;  ///< inverse of [v1-v0 v2-v0 v3-v0], input frame: barycentric coordinates
  Eigen::Vector3d v0;    ///< input frame
  /// Bound of the rounding error of the barycentric coordinates. Beyond it their sign is
  /// certain; within it (a point on a face, or a needle-shaped tetrahedron) exact orientation
  /// predicates on the source coordinates decide, as CGAL's own location does.
  double tolerance = 0.0;
  std::array<int, 4> neighbour;  ///< across the face opposite vertex i; -1 beyond the hull
};
static_assert(sizeof(LocatorTet) == 128, "a LocatorTet fills two cache lines");

/// The face of t that p certainly lies beyond (0-3, opposite vertex i; the most negative
/// barycentric coordinate), -1 when p lies inside beyond the rounding error, kInDoubt when p lies
/// on or near a face (or t is needle-shaped): then the exact test decides. One evaluation serves
/// both the test of a guess and a walk's first step.
constexpr int kInDoubt = 4;
inline int certainExit(const LocatorTet& t, const Eigen::Vector3d& p) {
  const Eigen::Vector3d l = t.bary * (p - t.v0);
  const double l3 = 1.0 - l.sum();
  const double lowest = std::min(std::min(l.x(), l.y()), std::min(l.z(), l3));
  if (lowest >= t.tolerance) return -1;  // the common case first, without the face's search
  if (lowest >= -t.tolerance) return kInDoubt;
  if (l3 == lowest) return 0;
  return l.x() == lowest ? 1 : l.y() == lowest ? 2 : 3;
}

/// Where a visibility walk stopped: in tetrahedron `tet`, with `face` its last answer: -1 (the
/// point lies in it), kBeyondHull (the face to leave by has no neighbour) or kInDoubt.
constexpr int kBeyondHull = 5;
struct WalkEnd {
  int tet;
  int face;
};

/// A visibility walk from tetrahedron `tet` over the neighbours, for at most `steps` steps;
/// exit(t) names the face of t the point lies beyond (-1 inside). A kInDoubt answer, or the
/// steps running out, stops it with kInDoubt.
template <typename Exit>
inline WalkEnd walkWith(const std::vector<LocatorTet>& tets, int tet, std::size_t steps,
                        const Exit& exit) {
  for (std::size_t step = 0; step < steps; ++step) {
    const int face = exit(tet);
    if (face < 0 || face == kInDoubt) return {tet, face};
    const int next = tets[static_cast<std::size_t>(tet)].neighbour[static_cast<std::size_t>(face)];
    if (next < 0) return {tet, kBeyondHull};
    tet = next;
  }
  return {tet, kInDoubt};
}

class TetLocator {
 public:
  struct Location {
    int tet = -1;
    bool outside = false;  ///< beyond the hull; tet is the hull tetrahedron the walk left by
  };

  /// `tets`, their `vertices` (source indices, positively oriented: CGAL's order) and `sources`
  /// (the vertices, source frame) must outlive the locator; input points map to the source
  /// frame by input_to_source; lo/hi (input frame) bound every vertex.
  TetLocator(const std::vector<LocatorTet>& tets, const std::vector<std::array<int, 4>>& vertices,
             const std::vector<Eigen::Vector3d>& sources, const Eigen::Isometry3d& input_to_source,
             const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);

  /// Builds the grid (on `threads` threads); until then locate() walks from tetrahedron 0.
  /// `sample` (optional) are points like those that will be located: mixed cells that hold
  /// some of them get sub-cells, so the budget goes where the points are; without a sample the
  /// grid stays at level 1.
  void build(int threads, const std::vector<Eigen::Vector3d>* sample = nullptr);
  Location locate(const Eigen::Vector3d& p) const;
  /// Visibility walk from tetrahedron `start`.
  Location walk(const Eigen::Vector3d& p, int start) const;
  /// Whether p lies in the tetrahedron (on its faces included).
  bool inside(int tet, const Eigen::Vector3d& p) const { return exit(tet, p) < 0; }

  Eigen::Vector3i gridSize() const { return n_; }
  /// Sub-cells in all blocks (memory: 4 bytes each).
  std::size_t subCells() const { return sub_.size(); }

 private:
  struct Block {
    int s = 1;               ///< sub-cells per axis
    std::size_t offset = 0;  ///< first sub-cell in sub_
  };

  Location bruteForce(const Eigen::Vector3d& p) const;
  Eigen::Vector3d corner(int x, int y, int z) const;
  std::size_t cellOf(const Eigen::Vector3d& p) const;
  using Candidates = std::array<int, 4>;  ///< tetrahedra to test, -1 padded
  struct SubBlock {
    std::vector<int> sub;  ///< >= 0 full; < 0: -(candidates + 1), local index
    std::vector<Candidates> candidates;
  };
  /// A level-1 cell that is not inside one tetrahedron.
  struct MixedCell {
    int x, y, z;
    int hint;       ///< the tetrahedron at its first corner: a start for the walk
    bool occupied;  ///< holds sample points
  };

  // The steps of build().
  void sizeGrid();
  std::vector<Location> locateGridVertices(int threads) const;
  std::vector<bool> occupiedCells(const std::vector<Eigen::Vector3d>* sample) const;
  /// Fills cell_ for the cells inside one tetrahedron; returns the others.
  std::vector<MixedCell> classifyCells(const std::vector<Location>& vertex,
                                       const std::vector<bool>& occupied);
  std::vector<SubBlock> subdivideMixed(const std::vector<MixedCell>& mixed, int threads) const;
  SubBlock subdivideOne(const MixedCell& c, int s_max) const;
  void packBlocks(const std::vector<SubBlock>& subs);

  /// Sub-cells of level-1 cell (x, y, z) at resolution s.
  SubBlock subdivide(int x, int y, int z, int s, int hint, double* full_fraction) const;
  /// -1 when p lies in the tetrahedron, else a face (opposite vertex i) p lies beyond.
  int exit(int tet, const Eigen::Vector3d& p) const;
  int exactExit(int tet, const Eigen::Vector3d& p) const;

  const std::vector<LocatorTet>& tets_;
  const std::vector<std::array<int, 4>>& vertices_;
  const std::vector<Eigen::Vector3d>& sources_;
  Eigen::Isometry3d input_to_source_;
  Eigen::Vector3d lo_, hi_;
  Eigen::Vector3d scale_ = Eigen::Vector3d::Zero();
  Eigen::Vector3i n_ = Eigen::Vector3i::Zero();
  std::vector<int> cell_;  ///< >= 0: the cell lies in that tetrahedron; < 0: -(block + 1)
  std::vector<Block> blocks_;
  std::vector<int> sub_;  ///< >= 0: the sub-cell lies in that tetrahedron; < 0: -(list + 1)
  std::vector<Candidates> candidates_;
};

}  // namespace flexcloud
