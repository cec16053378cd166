#pragma once
// Hashing of integer grid cells, for the spatial look-ups of the core (private to it).

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <unordered_map>

namespace flexcloud {

/// A grid cell's integer coordinates: 64-bit, since UTM-size coordinates in millimetre cells
/// (4e9) pass the range of int.
using Cell = Eigen::Matrix<std::int64_t, 3, 1>;

struct CellHash {
  std::size_t operator()(const Cell& k) const {
    return (static_cast<std::size_t>(k.x()) * 73856093u) ^
           (static_cast<std::size_t>(k.y()) * 19349663u) ^
           (static_cast<std::size_t>(k.z()) * 83492791u);
  }
};

struct CellEq {
  bool operator()(const Cell& a, const Cell& b) const { return a == b; }
};

/// Buckets of indices by grid cell.
template <typename T>
using CellMap = std::unordered_map<Cell, T, CellHash, CellEq>;

/// The cell of p in a grid of the given cell size. Coordinates beyond +-1e18 cells (no real
/// place) share the outermost cell: the callers compare the true distances within a cell.
inline Cell cellOf(const Eigen::Vector3d& p, double size) {
  Cell c;
  for (int i = 0; i < 3; ++i) {
    const double k = std::floor(p[i] / size);
    c[i] = std::isfinite(k) ? static_cast<std::int64_t>(std::clamp(k, -1e18, 1e18)) : 0;
  }
  return c;
}

}  // namespace flexcloud
