#include "sheet/tet_locator.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>

#include "parallel.h"

namespace flexcloud {
namespace {

constexpr std::size_t kCellsPerTet = 8;  // level-1 cells per tetrahedron
constexpr std::size_t kMinCells = 1 << 12;
constexpr std::size_t kMaxCells = 1 << 21;
constexpr std::size_t kSubBudget = 1 << 21;  // sub-cells in all blocks (4 + up to 16 bytes each)
constexpr int kMaxSub = 16;
constexpr double kFullEnough = 0.8;  // stop refining a block once this share is full

}  // namespace

TetLocator::TetLocator(const std::vector<LocatorTet>& tets,
                       const std::vector<std::array<int, 4>>& vertices,
                       const std::vector<Eigen::Vector3d>& sources,
                       const Eigen::Isometry3d& input_to_source, const Eigen::Vector3d& lo,
                       const Eigen::Vector3d& hi)
    : tets_(tets),
      vertices_(vertices),
      sources_(sources),
      input_to_source_(input_to_source),
      lo_(lo),
      hi_(hi) {}

int TetLocator::exit(int tet, const Eigen::Vector3d& p) const {
  const int face = certainExit(tets_[static_cast<std::size_t>(tet)], p);
  return face == kInDoubt ? exactExit(tet, p) : face;
}

int TetLocator::exactExit(int tet, const Eigen::Vector3d& p) const {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  const Eigen::Vector3d q = input_to_source_ * p;  // as CGAL's own location sees the point
  std::array<K::Point_3, 4> v;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d& s =
        sources_[static_cast<std::size_t>(vertices_[static_cast<std::size_t>(tet)][i])];
    v[i] = K::Point_3(s.x(), s.y(), s.z());
  }
  for (int i = 0; i < 4; ++i) {
    std::array<K::Point_3, 4> w = v;
    w[i] = K::Point_3(q.x(), q.y(), q.z());
    if (CGAL::orientation(w[0], w[1], w[2], w[3]) == CGAL::NEGATIVE) return i;
  }
  return -1;
}

TetLocator::Location TetLocator::walk(const Eigen::Vector3d& p, int start) const {
  const WalkEnd end =
      walkWith(tets_, start, 4 * tets_.size() + 64, [&](int tet) { return exit(tet, p); });
  // The steps ran out: never seen, a visibility walk in a Delaunay triangulation ends.
  if (end.face == kInDoubt) return bruteForce(p);
  return {end.tet, end.face == kBeyondHull};
}

TetLocator::Location TetLocator::bruteForce(const Eigen::Vector3d& p) const {
  for (std::size_t i = 0; i < tets_.size(); ++i) {
    if (exit(static_cast<int>(i), p) < 0) return {static_cast<int>(i), false};
  }
  for (std::size_t i = 0; i < tets_.size(); ++i) {  // outside: a tetrahedron on the hull
    for (int nb : tets_[i].neighbour) {
      if (nb < 0) return {static_cast<int>(i), true};
    }
  }
  return {0, true};
}

TetLocator::Location TetLocator::locate(const Eigen::Vector3d& p) const {
  if ((p.array() < lo_.array()).any() || (p.array() > hi_.array()).any()) return {-1, true};
  if (cell_.empty()) return walk(p, 0);
  const Eigen::Vector3d f = (p - lo_).cwiseProduct(scale_);
  const int ix = std::min(static_cast<int>(f.x()), n_.x() - 1);
  const int iy = std::min(static_cast<int>(f.y()), n_.y() - 1);
  const int iz = std::min(static_cast<int>(f.z()), n_.z() - 1);
  const int v = cell_[(static_cast<std::size_t>(iz) * n_.y() + iy) * n_.x() + ix];
  if (v >= 0) return {v, false};
  const Block& b = blocks_[static_cast<std::size_t>(-v - 1)];
  const int sx = std::min(static_cast<int>((f.x() - ix) * b.s), b.s - 1);
  const int sy = std::min(static_cast<int>((f.y() - iy) * b.s), b.s - 1);
  const int sz = std::min(static_cast<int>((f.z() - iz) * b.s), b.s - 1);
  const int w = sub_[b.offset + (static_cast<std::size_t>(sz) * b.s + sy) * b.s + sx];
  if (w >= 0) return {w, false};
  const Candidates& c = candidates_[static_cast<std::size_t>(-w - 1)];
  for (int t : c) {
    if (t < 0) break;
    if (inside(t, p)) return {t, false};
  }
  return walk(p, c[0]);
}

std::size_t TetLocator::cellOf(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d f = (p - lo_).cwiseProduct(scale_);
  const int ix = std::clamp(static_cast<int>(f.x()), 0, n_.x() - 1);
  const int iy = std::clamp(static_cast<int>(f.y()), 0, n_.y() - 1);
  const int iz = std::clamp(static_cast<int>(f.z()), 0, n_.z() - 1);
  return (static_cast<std::size_t>(iz) * n_.y() + iy) * n_.x() + ix;
}

Eigen::Vector3d TetLocator::corner(int x, int y, int z) const {
  return lo_ + Eigen::Vector3d(x, y, z).cwiseQuotient(scale_);
}

TetLocator::SubBlock TetLocator::subdivide(int x, int y, int z, int s, int hint,
                                           double* full_fraction) const {
  const int m = s + 1;
  const Eigen::Vector3d c0 = corner(x, y, z);
  const Eigen::Vector3d step = Eigen::Vector3d::Ones().cwiseQuotient(scale_) / s;
  std::vector<Location> vertex(static_cast<std::size_t>(m) * m * m);
  for (int k = 0; k < m; ++k) {
    for (int j = 0; j < m; ++j) {
      for (int i = 0; i < m; ++i) {
        const Location loc = walk(c0 + Eigen::Vector3d(i, j, k).cwiseProduct(step), hint);
        hint = loc.tet;
        vertex[(static_cast<std::size_t>(k) * m + j) * m + i] = loc;
      }
    }
  }
  SubBlock out;
  out.sub.resize(static_cast<std::size_t>(s) * s * s);
  std::size_t full = 0;
  for (int k = 0; k < s; ++k) {
    for (int j = 0; j < s; ++j) {
      for (int i = 0; i < s; ++i) {
        Candidates c{-1, -1, -1, -1};
        std::size_t count = 0;
        bool inside_one = true;
        for (int q = 0; q < 8; ++q) {
          const Location& v =
              vertex[(static_cast<std::size_t>(k + (q >> 2)) * m + j + ((q >> 1) & 1)) * m + i +
                     (q & 1)];
          inside_one = inside_one && !v.outside &&
                       v.tet == vertex[(static_cast<std::size_t>(k) * m + j) * m + i].tet;
          if (v.outside || count == c.size() ||
              std::find(c.begin(), c.begin() + static_cast<std::ptrdiff_t>(count), v.tet) !=
                  c.begin() + static_cast<std::ptrdiff_t>(count)) {
            continue;
          }
          c[count++] = v.tet;
        }
        int& entry = out.sub[(static_cast<std::size_t>(k) * s + j) * s + i];
        if (inside_one) {
          ++full;
          entry = c[0];
        } else {
          if (count == 0) c[0] = vertex[(static_cast<std::size_t>(k) * m + j) * m + i].tet;
          entry = -static_cast<int>(out.candidates.size()) - 1;
          out.candidates.push_back(c);
        }
      }
    }
  }
  *full_fraction = static_cast<double>(full) / static_cast<double>(out.sub.size());
  return out;
}

void TetLocator::build(int threads, const std::vector<Eigen::Vector3d>* sample) {
  sizeGrid();
  const std::vector<Location> vertex = locateGridVertices(threads);
  const std::vector<MixedCell> mixed = classifyCells(vertex, occupiedCells(sample));
  packBlocks(subdivideMixed(mixed, threads));
}

void TetLocator::sizeGrid() {
  const Eigen::Vector3d extent = (hi_ - lo_).cwiseMax(1e-9);
  const std::size_t wanted = std::clamp(kCellsPerTet * tets_.size(), kMinCells, kMaxCells);
  const double h = std::cbrt(extent.prod() / static_cast<double>(wanted));
  for (int a = 0; a < 3; ++a) {
    n_(a) = static_cast<int>(std::clamp(std::ceil(extent(a) / h), 1.0, 2048.0));
    scale_(a) = n_(a) / extent(a);
  }
}

std::vector<TetLocator::Location> TetLocator::locateGridVertices(int threads) const {
  // Each thread walks its slabs, starting where it ended.
  const int nx = n_.x() + 1, ny = n_.y() + 1, nz = n_.z() + 1;
  std::vector<Location> vertex(static_cast<std::size_t>(nx) * ny * nz);
  parallelRanges(static_cast<std::size_t>(nz), static_cast<std::size_t>(threadCount(threads)),
                 threads, [&](std::size_t, std::size_t z0, std::size_t z1) {
                   int hint = 0;
                   for (auto z = static_cast<int>(z0); z < static_cast<int>(z1); ++z) {
                     for (int y = 0; y < ny; ++y) {
                       for (int x = 0; x < nx; ++x) {
                         const Location loc = walk(corner(x, y, z), hint);
                         hint = loc.tet;
                         vertex[(static_cast<std::size_t>(z) * ny + y) * nx + x] = loc;
                       }
                     }
                   }
                 });
  return vertex;
}

std::vector<bool> TetLocator::occupiedCells(const std::vector<Eigen::Vector3d>* sample) const {
  // Sub-cells only where sample points are: without a sample (a few points to transform, not a
  // map) level 1 and the walk do.
  std::vector<bool> occupied(static_cast<std::size_t>(n_.prod()), false);
  if (sample == nullptr) return occupied;
  for (const auto& p : *sample) {
    if (p.allFinite() && (p.array() >= lo_.array()).all() && (p.array() <= hi_.array()).all()) {
      occupied[cellOf(p)] = true;
    }
  }
  return occupied;
}

std::vector<TetLocator::MixedCell> TetLocator::classifyCells(const std::vector<Location>& vertex,
                                                             const std::vector<bool>& occupied) {
  const int nx = n_.x() + 1, ny = n_.y() + 1;
  auto at = [&](int x, int y, int z) -> const Location& {
    return vertex[(static_cast<std::size_t>(z) * ny + y) * nx + x];
  };
  cell_.assign(static_cast<std::size_t>(n_.prod()), 0);
  std::vector<MixedCell> mixed;
  for (int z = 0; z < n_.z(); ++z) {
    for (int y = 0; y < n_.y(); ++y) {
      for (int x = 0; x < n_.x(); ++x) {
        const Location& first = at(x, y, z);
        bool inside = !first.outside;
        for (int c = 1; c < 8 && inside; ++c) {
          const Location& o = at(x + (c & 1), y + ((c >> 1) & 1), z + (c >> 2));
          inside = !o.outside && o.tet == first.tet;
        }
        const std::size_t idx = (static_cast<std::size_t>(z) * n_.y() + y) * n_.x() + x;
        if (inside) {
          cell_[idx] = first.tet;
        } else {
          cell_[idx] = -static_cast<int>(mixed.size()) - 1;
          mixed.push_back({x, y, z, first.tet, occupied[idx]});
        }
      }
    }
  }
  return mixed;
}

std::vector<TetLocator::SubBlock> TetLocator::subdivideMixed(const std::vector<MixedCell>& mixed,
                                                             int threads) const {
  // As fine as the budget allows (shared by the mixed cells that hold sample points) and the
  // cell needs.
  std::size_t busy = 0;
  for (const auto& c : mixed) busy += c.occupied ? 1 : 0;
  const int s_max = static_cast<int>(std::clamp(
      std::floor(std::cbrt(static_cast<double>(kSubBudget) / std::max<std::size_t>(1, busy))), 1.0,
      static_cast<double>(kMaxSub)));
  std::vector<SubBlock> subs(mixed.size());
  parallelRanges(mixed.size(), static_cast<std::size_t>(threadCount(threads)), threads,
                 [&](std::size_t, std::size_t b0, std::size_t b1) {
                   for (std::size_t b = b0; b < b1; ++b) subs[b] = subdivideOne(mixed[b], s_max);
                 });
  return subs;
}

TetLocator::SubBlock TetLocator::subdivideOne(const MixedCell& c, int s_max) const {
  if (!c.occupied) {  // no sample point here: a single sub-cell, a start for the walk
    SubBlock one;
    one.sub = {-1};
    one.candidates = {{c.hint, -1, -1, -1}};
    return one;
  }
  // A coarse try first; cells that stay mostly mixed get the finest the budget allows.
  const int s = std::min(4, s_max);
  double full = 0.0;
  SubBlock block = subdivide(c.x, c.y, c.z, s, c.hint, &full);
  if (full < kFullEnough && s < s_max) block = subdivide(c.x, c.y, c.z, s_max, c.hint, &full);
  return block;
}

void TetLocator::packBlocks(const std::vector<SubBlock>& subs) {
  blocks_.resize(subs.size());
  std::size_t total = 0, lists = 0;
  for (const auto& s : subs) total += s.sub.size(), lists += s.candidates.size();
  sub_.clear();
  candidates_.clear();
  sub_.reserve(total);
  candidates_.reserve(lists);
  for (std::size_t b = 0; b < subs.size(); ++b) {
    blocks_[b].s =
        static_cast<int>(std::lround(std::cbrt(static_cast<double>(subs[b].sub.size()))));
    blocks_[b].offset = sub_.size();
    const int base = static_cast<int>(candidates_.size());
    for (int e : subs[b].sub) sub_.push_back(e >= 0 ? e : e - base);
    candidates_.insert(candidates_.end(), subs[b].candidates.begin(), subs[b].candidates.end());
  }
}

}  // namespace flexcloud
