#pragma once
// Which positions of a trajectory lie near a point, through a hash grid (private to the core).

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "cell_hash.h"
#include "flexcloud/types.h"

namespace flexcloud {

/// Nearest-neighbour queries on the SLAM positions through a hash grid.
class PositionGrid {
 public:
  PositionGrid(const Trajectory& poses, double cell) : cell_(cell) {
    for (const auto& p : poses) cells_[cellOf(p.position, cell_)].push_back(p.position);
  }
  PositionGrid(const std::vector<Eigen::Vector3d>& points, double cell) : cell_(cell) {
    for (const auto& p : points) cells_[cellOf(p, cell_)].push_back(p);
  }
  /// Whether a position lies within `radius` of p.
  bool anyWithin(const Eigen::Vector3d& p, double radius) const {
    const int reach = static_cast<int>(std::ceil(radius / cell_));
    const Cell c = cellOf(p, cell_);
    for (int dx = -reach; dx <= reach; ++dx) {
      for (int dy = -reach; dy <= reach; ++dy) {
        for (int dz = -reach; dz <= reach; ++dz) {
          const auto it = cells_.find(c + Cell(dx, dy, dz));
          if (it == cells_.end()) continue;
          for (const auto& q : it->second) {
            if ((q - p).norm() < radius) return true;
          }
        }
      }
    }
    return false;
  }

 private:
  double cell_;
  CellMap<std::vector<Eigen::Vector3d>> cells_;
};

}  // namespace flexcloud
