#include "flexcloud/sheet/rubber_sheet.h"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>

#include "cell_hash.h"
#include "sheet/tet_locator.h"

namespace flexcloud {

struct RubberSheet::Cgal {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using Vb = CGAL::Triangulation_vertex_base_with_info_3<int, K>;
  using Cb = CGAL::Triangulation_cell_base_with_info_3<int, K,
                                                       CGAL::Delaunay_triangulation_cell_base_3<K>>;
  using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb>;
  using Delaunay = CGAL::Delaunay_triangulation_3<K, Tds>;
  using Point = K::Point_3;
  Delaunay dt;
  /// Per tetrahedron (by its cell's number): the inverse of its edge matrix in the source frame
  /// and whether it is flat; what a retargeted sheet needs besides its targets.
  std::vector<Eigen::Matrix3d, Eigen::aligned_allocator<Eigen::Matrix3d>> bary;
  std::vector<char> flat;
};

namespace {

constexpr double kMergeDistance = 1e-3;  // m: sources closer than this are one point
constexpr double kFlatQuality = 1e-9;    // |det(edges)| / longest^3 below this: a flat sliver

/// Keeps the first of any sources within kMergeDistance of each other.
std::vector<std::size_t> mergeNearDuplicates(const std::vector<Eigen::Vector3d>& pts) {
  CellMap<std::vector<std::size_t>> buckets;
  std::vector<std::size_t> kept;
  kept.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Cell key = cellOf(pts[i], kMergeDistance);
    bool duplicate = false;
    for (int dx = -1; dx <= 1 && !duplicate; ++dx) {
      for (int dy = -1; dy <= 1 && !duplicate; ++dy) {
        for (int dz = -1; dz <= 1 && !duplicate; ++dz) {
          const auto it = buckets.find(key + Cell(dx, dy, dz));
          if (it == buckets.end()) continue;
          for (std::size_t j : it->second) {
            if ((pts[j] - pts[i]).norm() < kMergeDistance) duplicate = true;
          }
        }
      }
    }
    if (duplicate) continue;
    buckets[key].push_back(i);
    kept.push_back(i);
  }
  return kept;
}

}  // namespace

namespace {

/// Error for counts that differ or a point that is not finite.
void checkPairs(std::size_t sources, const std::vector<Eigen::Vector3d>& target,
                const std::vector<Eigen::Vector3d>* source = nullptr) {
  if (sources != target.size()) {
    throw Error("rubber sheet: " + std::to_string(sources) + " source points but " +
                std::to_string(target.size()) + " targets");
  }
  for (std::size_t i = 0; i < target.size(); ++i) {
    if (!target[i].allFinite() || (source != nullptr && !(*source)[i].allFinite())) {
      throw Error("rubber sheet: control point " + std::to_string(i) + " is not finite");
    }
  }
}

}  // namespace

RubberSheet::RubberSheet(const std::vector<Eigen::Vector3d>& source,
                         const std::vector<Eigen::Vector3d>& target, const Affine34& outside,
                         const Eigen::Isometry3d& input_to_source)
    : outside_(outside), input_to_source_(input_to_source), cgal_(std::make_shared<Cgal>()) {
  checkPairs(source.size(), target, &source);
  kept_ = mergeNearDuplicates(source);
  merged_ = source.size() - kept_.size();
  std::vector<std::pair<Cgal::Point, int>> points;
  points.reserve(kept_.size());
  for (std::size_t i : kept_) {
    const int idx = static_cast<int>(source_.size());
    source_.push_back(source[i]);
    target_.push_back(target[i]);
    points.emplace_back(Cgal::Point(source[i].x(), source[i].y(), source[i].z()), idx);
  }
  auto& dt = cgal_->dt;
  dt.insert(points.begin(), points.end());
  if (dt.dimension() < 3) {
    throw Error("rubber sheet: the " + std::to_string(source_.size()) +
                " control points span no volume (degenerate triangulation)");
  }
  int next = 0;
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) c->info() = next++;
  buildGeometry();
  buildAffine();
  makeLocator();
}

RubberSheet::RubberSheet(const RubberSheet& shape, const std::vector<Eigen::Vector3d>& target,
                         const Affine34& outside)
    : source_(shape.source_),
      outside_(outside),
      merged_(shape.merged_),
      input_to_source_(shape.input_to_source_),
      geometry_(shape.geometry_),
      tet_vertices_(shape.tet_vertices_),
      kept_(shape.kept_),
      cgal_(shape.cgal_) {
  target_.reserve(kept_.size());
  for (std::size_t i : kept_) target_.push_back(target[i]);
  buildAffine();
  makeLocator();
}

std::shared_ptr<const RubberSheet> RubberSheet::retargeted(
    const std::vector<Eigen::Vector3d>& target, const Affine34& outside) const {
  checkPairs(kept_.size() + merged_, target);
  return std::shared_ptr<const RubberSheet>(new RubberSheet(*this, target, outside));
}

void RubberSheet::makeLocator() {
  // The locator's box: every source, in the input frame.
  const Eigen::Isometry3d source_to_input = input_to_source_.inverse();
  Eigen::Vector3d lo = source_to_input * source_.front();
  Eigen::Vector3d hi = lo;
  for (const auto& src : source_) {
    lo = lo.cwiseMin(source_to_input * src);
    hi = hi.cwiseMax(source_to_input * src);
  }
  input_box_ = Eigen::AlignedBox3d(lo, hi);
  locator_ =
      std::make_unique<TetLocator>(geometry_, tet_vertices_, source_, input_to_source_, lo, hi);
}

void RubberSheet::buildGeometry() {
  // Reads the triangulation only (its cells were numbered where it was built). What depends on
  // the sources alone stays in cgal_ for the sheets retargeted from this one: each
  // tetrahedron's inverse edge matrix and whether it is flat.
  Cgal& cgal = *cgal_;
  const auto& dt = cgal.dt;
  const auto n = static_cast<std::size_t>(dt.number_of_finite_cells());
  geometry_.resize(n);
  tet_vertices_.resize(n);
  cgal.bary.resize(n);
  cgal.flat.assign(n, 0);
  const Eigen::Matrix3d rot = input_to_source_.linear();
  const Eigen::Isometry3d source_to_input = input_to_source_.inverse();
  const double back_shift = input_to_source_.translation().norm();
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
    const auto t = static_cast<std::size_t>(c->info());
    std::array<int, 4>& v = tet_vertices_[t];
    LocatorTet& tet = geometry_[t];
    for (int i = 0; i < 4; ++i) {
      v[i] = c->vertex(i)->info();
      const auto nb = c->neighbor(i);
      tet.neighbour[i] = dt.is_infinite(nb) ? -1 : nb->info();
    }
    tetGeometry(t, rot, source_to_input, back_shift);
  }
}

void RubberSheet::tetGeometry(std::size_t t, const Eigen::Matrix3d& rot,
                              const Eigen::Isometry3d& source_to_input, double back_shift) {
  const std::array<int, 4>& v = tet_vertices_[t];
  const auto& s = source_;
  Eigen::Matrix3d edges;
  double longest = 0.0;
  for (int i = 0; i < 3; ++i) {
    edges.col(i) = s[v[i + 1]] - s[v[0]];
    longest = std::max(longest, edges.col(i).norm());
  }
  cgal_->flat[t] = std::abs(edges.determinant()) < kFlatQuality * longest * longest * longest;
  // Householder QR with full pivoting, as in the published method, on vertex-relative
  // coordinates so that large coordinates do not cost precision.
  const Eigen::FullPivHouseholderQR<Eigen::Matrix3d> qr(edges);
  const Eigen::Matrix3d bary = qr.solve(Eigen::Matrix3d::Identity());
  cgal_->bary[t] = bary;
  // Fold the input -> source transform in: input point q lies at input_to_source * q.
  LocatorTet& tet = geometry_[t];
  tet.bary = bary * rot;
  tet.v0 = source_to_input * s[v[0]];
  // Rounding of the barycentric coordinates: the inverse's own (conditioning), that of
  // subtracting coordinates of this magnitude, and that of v0, which came back from the
  // source frame through the alignment (with the GNSS in UTM-size coordinates both are
  // thousands of kilometres, and v0 keeps their rounding); 256 eps of all is a safe bound.
  const double cond = edges.norm() * bary.norm();
  const double back = s[v[0]].norm() + back_shift;
  tet.tolerance = 256.0 * std::numeric_limits<double>::epsilon() *
                  (cond + bary.norm() * (tet.v0.norm() + longest + back));
}

void RubberSheet::buildAffine() {
  const Cgal& cgal = *cgal_;
  const std::size_t n = tet_vertices_.size();
  affine_.resize(n);
  const Eigen::Matrix3d rot = input_to_source_.linear();
  const Eigen::Vector3d shift = input_to_source_.translation();
  for (std::size_t t = 0; t < n; ++t) {
    const std::array<int, 4>& v = tet_vertices_[t];
    const auto& d = target_;
    Eigen::Matrix3d images;
    for (int i = 0; i < 3; ++i) images.col(i) = d[v[i + 1]] - d[v[0]];
    const Eigen::Matrix3d linear = images * cgal.bary[t];
    affine_[t].leftCols<3>() = linear * rot;
    affine_[t].col(3) = linear * (shift - source_[v[0]]) + d[v[0]];
  }
  replaceDegenerate(cgal.flat);
}

void RubberSheet::replaceDegenerate(const std::vector<char>& flat) {
  // A nearly flat tetrahedron has no reliable transform of its own; it holds almost no volume,
  // so it borrows the transform of the nearest solid tetrahedron across its faces.
  for (std::size_t t = 0; t < geometry_.size(); ++t) {
    if (!flat[t]) continue;
    ++degenerate_;
    std::vector<int> queue{static_cast<int>(t)};
    std::vector<bool> seen(geometry_.size(), false);
    seen[t] = true;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const int cur = queue[head];
      if (!flat[static_cast<std::size_t>(cur)]) {
        affine_[t] = affine_[static_cast<std::size_t>(cur)];
        break;
      }
      for (int nb : geometry_[static_cast<std::size_t>(cur)].neighbour) {
        if (nb >= 0 && !seen[static_cast<std::size_t>(nb)]) {
          seen[static_cast<std::size_t>(nb)] = true;
          queue.push_back(nb);
        }
      }
    }
  }
}

RubberSheet::~RubberSheet() = default;

void RubberSheet::prepare(int threads, const std::vector<Eigen::Vector3d>* sample) const {
  std::call_once(grid_once_, [&] {
    locator_->build(threads, sample);
    prepared_.store(true, std::memory_order_release);
  });
}

Eigen::Vector3i RubberSheet::gridSize() const { return locator_->gridSize(); }

RubberSheet::Location RubberSheet::locate(const Eigen::Vector3d& p) const {
  prepare();
  const TetLocator::Location l = locator_->locate(p);
  return {l.tet, l.outside};
}

RubberSheet::Location RubberSheet::locateFrom(const Eigen::Vector3d& p, int hint) const {
  const bool valid = hint >= 0 && static_cast<std::size_t>(hint) < geometry_.size();
  const TetLocator::Location l = locator_->walk(p, valid ? hint : 0);
  return {l.tet, l.outside};
}

Eigen::Vector3d RubberSheet::transformReference(const Eigen::Vector3d& p, bool* outside) const {
  const auto& dt = cgal_->dt;
  const Eigen::Vector3d q = input_to_source_ * p;
  const auto cell = dt.locate(Cgal::Point(q.x(), q.y(), q.z()));
  const bool out = dt.is_infinite(cell);
  if (outside != nullptr) *outside = out;
  return apply(out ? outside_ : affine_[static_cast<std::size_t>(cell->info())], p);
}

}  // namespace flexcloud
