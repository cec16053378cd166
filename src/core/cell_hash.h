#pragma once
// Hashing of integer grid cells, for the spatial look-ups of the core (private to it).

#include <Eigen/Core>
#include <cstddef>
#include <unordered_map>

namespace flexcloud {

struct CellHash {
  std::size_t operator()(const Eigen::Vector3i& k) const {
    return (static_cast<std::size_t>(k.x()) * 73856093u) ^
           (static_cast<std::size_t>(k.y()) * 19349663u) ^
           (static_cast<std::size_t>(k.z()) * 83492791u);
  }
};

struct CellEq {
  bool operator()(const Eigen::Vector3i& a, const Eigen::Vector3i& b) const { return a == b; }
};

/// Buckets of indices by grid cell.
template <typename T>
using CellMap = std::unordered_map<Eigen::Vector3i, T, CellHash, CellEq>;

/// The cell of p in a grid of the given cell size.
inline Eigen::Vector3i cellOf(const Eigen::Vector3d& p, double size) {
  return (p / size).array().floor().cast<int>();
}

}  // namespace flexcloud
