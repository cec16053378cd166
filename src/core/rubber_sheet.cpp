#include "flexcloud/rubber_sheet.h"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

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
};

namespace {

constexpr double kMergeDistance = 1e-3;    // m: sources closer than this are one point
constexpr double kInsideTolerance = -1e-12;  // barycentric slack for points on faces
constexpr double kFlatQuality = 1e-9;  // |det(edges)| / longest^3 below this: a flat sliver
constexpr std::size_t kCellsPerTet = 48;
constexpr std::size_t kMinCells = 1 << 12;
constexpr std::size_t kMaxCells = 1 << 22;

/// Keeps the first of any sources within kMergeDistance of each other.
std::vector<std::size_t> mergeNearDuplicates(const std::vector<Eigen::Vector3d>& pts) {
  struct Hash {
    std::size_t operator()(const Eigen::Vector3i& k) const {
      return (static_cast<std::size_t>(k.x()) * 73856093u) ^
             (static_cast<std::size_t>(k.y()) * 19349663u) ^
             (static_cast<std::size_t>(k.z()) * 83492791u);
    }
  };
  struct Eq {
    bool operator()(const Eigen::Vector3i& a, const Eigen::Vector3i& b) const { return a == b; }
  };
  std::unordered_map<Eigen::Vector3i, std::vector<std::size_t>, Hash, Eq> buckets;
  std::vector<std::size_t> kept;
  kept.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3i key = (pts[i] / kMergeDistance).array().floor().cast<int>();
    bool duplicate = false;
    for (int dx = -1; dx <= 1 && !duplicate; ++dx) {
      for (int dy = -1; dy <= 1 && !duplicate; ++dy) {
        for (int dz = -1; dz <= 1 && !duplicate; ++dz) {
          const auto it = buckets.find(key + Eigen::Vector3i(dx, dy, dz));
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

RubberSheet::RubberSheet(const std::vector<Eigen::Vector3d>& source,
                         const std::vector<Eigen::Vector3d>& target, const Affine34& outside,
                         const Eigen::Isometry3d& input_to_source, bool with_grid)
    : outside_(outside), input_to_source_(input_to_source), cgal_(std::make_unique<Cgal>()) {
  if (source.size() != target.size()) {
    throw Error("rubber sheet: " + std::to_string(source.size()) + " source points but " +
                std::to_string(target.size()) + " targets");
  }
  for (std::size_t i = 0; i < source.size(); ++i) {
    if (!source[i].allFinite() || !target[i].allFinite()) {
      throw Error("rubber sheet: control point " + std::to_string(i) + " is not finite");
    }
  }
  const std::vector<std::size_t> kept = mergeNearDuplicates(source);
  merged_ = source.size() - kept.size();
  std::vector<std::pair<Cgal::Point, int>> points;
  points.reserve(kept.size());
  for (std::size_t i : kept) {
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
  buildTets(input_to_source);
  if (with_grid) buildGrid(input_to_source);
}

void RubberSheet::buildTets(const Eigen::Isometry3d& input_to_source) {
  auto& dt = cgal_->dt;
  int next = 0;
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) c->info() = next++;
  tets_.resize(static_cast<std::size_t>(next));
  tet_vertices_.resize(tets_.size());
  std::vector<bool> flat(tets_.size(), false);
  const Eigen::Matrix3d rot = input_to_source.linear();
  const Eigen::Isometry3d source_to_input = input_to_source.inverse();
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
    const auto t = static_cast<std::size_t>(c->info());
    Tet& tet = tets_[t];
    std::array<int, 4>& v = tet_vertices_[t];
    for (int i = 0; i < 4; ++i) {
      v[i] = c->vertex(i)->info();
      const auto nb = c->neighbor(i);
      tet.neighbour[i] = dt.is_infinite(nb) ? -1 : nb->info();
    }
    const auto& s = source_;
    const auto& d = target_;
    Eigen::Matrix3d edges;
    Eigen::Matrix3d images;
    double longest = 0.0;
    for (int i = 0; i < 3; ++i) {
      edges.col(i) = s[v[i + 1]] - s[v[0]];
      images.col(i) = d[v[i + 1]] - d[v[0]];
      longest = std::max(longest, edges.col(i).norm());
    }
    flat[t] = std::abs(edges.determinant()) < kFlatQuality * longest * longest * longest;
    // Householder QR with full pivoting, as in the published method, on vertex-relative
    // coordinates so that large coordinates do not cost precision.
    const Eigen::FullPivHouseholderQR<Eigen::Matrix3d> qr(edges);
    const Eigen::Matrix3d bary = qr.solve(Eigen::Matrix3d::Identity());
    const Eigen::Matrix3d linear = images * bary;
    // Fold the input -> source transform in: input point q lies at input_to_source * q.
    tet.bary = bary * rot;
    tet.v0 = source_to_input * s[v[0]];
    tet.affine.leftCols<3>() = linear * rot;
    tet.affine.col(3) = linear * (input_to_source.translation() - s[v[0]]) + d[v[0]];
  }
  replaceDegenerate(flat);
}

void RubberSheet::replaceDegenerate(const std::vector<bool>& flat) {
  // A nearly flat tetrahedron has no reliable transform of its own; it holds almost no volume,
  // so it borrows the transform of the nearest solid tetrahedron across its faces.
  for (std::size_t t = 0; t < tets_.size(); ++t) {
    if (!flat[t]) continue;
    ++degenerate_;
    std::vector<int> queue{static_cast<int>(t)};
    std::vector<bool> seen(tets_.size(), false);
    seen[t] = true;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const int cur = queue[head];
      if (!flat[static_cast<std::size_t>(cur)]) {
        tets_[t].affine = tets_[static_cast<std::size_t>(cur)].affine;
        break;
      }
      for (int nb : tets_[static_cast<std::size_t>(cur)].neighbour) {
        if (nb >= 0 && !seen[static_cast<std::size_t>(nb)]) {
          seen[static_cast<std::size_t>(nb)] = true;
          queue.push_back(nb);
        }
      }
    }
  }
}

RubberSheet::~RubberSheet() = default;

RubberSheet::Location RubberSheet::walk(const Eigen::Vector3d& p, int start) const {
  int current = start;
  const std::size_t limit = 4 * tets_.size() + 64;
  for (std::size_t step = 0; step < limit; ++step) {
    const Tet& t = tets_[static_cast<std::size_t>(current)];
    const Eigen::Vector3d l = t.bary * (p - t.v0);
    const double l0 = 1.0 - l.sum();
    int worst = 0;
    double lowest = l0;
    for (int i = 0; i < 3; ++i) {
      if (l(i) < lowest) {
        lowest = l(i);
        worst = i + 1;
      }
    }
    if (lowest >= kInsideTolerance) return {current, false};
    const int next = t.neighbour[static_cast<std::size_t>(worst)];
    if (next < 0) return {current, true};
    current = next;
  }
  return bruteForce(p);  // a walk that cycles on a near-degenerate cell; never seen so far
}

RubberSheet::Location RubberSheet::bruteForce(const Eigen::Vector3d& p) const {
  int best = 0;
  double best_lowest = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < tets_.size(); ++i) {
    const Eigen::Vector3d l = tets_[i].bary * (p - tets_[i].v0);
    const double lowest = std::min(1.0 - l.sum(), l.minCoeff());
    if (lowest > best_lowest) {
      best_lowest = lowest;
      best = static_cast<int>(i);
    }
  }
  return {best, best_lowest < kInsideTolerance};
}

RubberSheet::Location RubberSheet::locateFrom(const Eigen::Vector3d& p, int hint) const {
  const bool valid = hint >= 0 && static_cast<std::size_t>(hint) < tets_.size();
  return walk(p, valid ? hint : 0);
}

RubberSheet::Location RubberSheet::locate(const Eigen::Vector3d& p) const {
  if (cell_.empty()) return walk(p, 0);
  if ((p.array() < grid_lo_.array()).any() || (p.array() > grid_hi_.array()).any()) {
    return {-1, true};
  }
  const Eigen::Vector3d f = (p - grid_lo_).cwiseProduct(grid_scale_);
  const int ix = std::min(static_cast<int>(f.x()), grid_n_.x() - 1);
  const int iy = std::min(static_cast<int>(f.y()), grid_n_.y() - 1);
  const int iz = std::min(static_cast<int>(f.z()), grid_n_.z() - 1);
  const int cell = cell_[(static_cast<std::size_t>(iz) * grid_n_.y() + iy) * grid_n_.x() + ix];
  if (cell >= 0) return {cell, false};
  return walk(p, -cell - 1);
}

void RubberSheet::buildGrid(const Eigen::Isometry3d& input_to_source) {
  const Eigen::Isometry3d source_to_input = input_to_source.inverse();
  grid_lo_ = source_to_input * source_.front();
  grid_hi_ = grid_lo_;
  for (const auto& s : source_) {
    grid_lo_ = grid_lo_.cwiseMin(source_to_input * s);
    grid_hi_ = grid_hi_.cwiseMax(source_to_input * s);
  }
  const Eigen::Vector3d extent = (grid_hi_ - grid_lo_).cwiseMax(1e-9);
  const std::size_t wanted = std::clamp(kCellsPerTet * tets_.size(), kMinCells, kMaxCells);
  const double h = std::cbrt(extent.prod() / static_cast<double>(wanted));
  for (int a = 0; a < 3; ++a) {
    grid_n_(a) = static_cast<int>(std::clamp(std::ceil(extent(a) / h), 1.0, 4096.0));
    grid_scale_(a) = grid_n_(a) / extent(a);
  }
  const int nx = grid_n_.x() + 1;
  const int ny = grid_n_.y() + 1;
  const int nz = grid_n_.z() + 1;
  // Locate every grid vertex, each walk starting where the previous one ended.
  std::vector<Location> vertex(static_cast<std::size_t>(nx) * ny * nz);
  int hint = 0;
  for (int z = 0; z < nz; ++z) {
    for (int y = 0; y < ny; ++y) {
      for (int x = 0; x < nx; ++x) {
        const Eigen::Vector3d p =
            grid_lo_ + Eigen::Vector3d(x, y, z).cwiseQuotient(grid_scale_);
        Location loc = walk(p, hint);
        hint = loc.tet;
        vertex[(static_cast<std::size_t>(z) * ny + y) * nx + x] = loc;
      }
    }
  }
  cell_.assign(static_cast<std::size_t>(grid_n_.prod()), 0);
  for (int z = 0; z < grid_n_.z(); ++z) {
    for (int y = 0; y < grid_n_.y(); ++y) {
      for (int x = 0; x < grid_n_.x(); ++x) {
        const Location& first = vertex[(static_cast<std::size_t>(z) * ny + y) * nx + x];
        bool full = !first.outside;
        for (int c = 1; c < 8 && full; ++c) {
          const Location& other =
              vertex[(static_cast<std::size_t>(z + (c >> 2)) * ny + y + ((c >> 1) & 1)) * nx + x +
                     (c & 1)];
          full = !other.outside && other.tet == first.tet;
        }
        cell_[(static_cast<std::size_t>(z) * grid_n_.y() + y) * grid_n_.x() + x] =
            full ? first.tet : -first.tet - 1;
      }
    }
  }
}

Eigen::Vector3d RubberSheet::transformReference(const Eigen::Vector3d& p, bool* outside) const {
  const auto& dt = cgal_->dt;
  const Eigen::Vector3d q = input_to_source_ * p;
  const auto cell = dt.locate(Cgal::Point(q.x(), q.y(), q.z()));
  const bool out = dt.is_infinite(cell);
  if (outside != nullptr) *outside = out;
  return apply(out ? outside_ : tets_[static_cast<std::size_t>(cell->info())].affine, p);
}

}  // namespace flexcloud
