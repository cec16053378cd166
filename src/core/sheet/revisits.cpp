#include "sheet/revisits.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "cell_hash.h"

namespace flexcloud {

namespace {

constexpr double kRadius = 5.0, kOtherPass = 50.0;

/// Pairs (i < j) of control points within kRadius of each other in `where`, more than kOtherPass
/// of path apart.
std::set<std::pair<std::size_t, std::size_t>> nearPairs(const std::vector<Eigen::Vector3d>& where,
                                                        const std::vector<double>& arc) {
  std::set<std::pair<std::size_t, std::size_t>> out;
  CellMap<std::vector<std::size_t>> cells;
  for (std::size_t i = 0; i < where.size(); ++i) cells[cellOf(where[i], kRadius)].push_back(i);
  for (std::size_t i = 0; i < where.size(); ++i) {
    const Cell key = cellOf(where[i], kRadius);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find(key + Cell(dx, dy, dz));
          if (it == cells.end()) continue;
          for (std::size_t j : it->second) {
            if (j > i && (where[j] - where[i]).norm() <= kRadius &&
                std::abs(arc[j] - arc[i]) >= kOtherPass) {
              out.emplace(i, j);
            }
          }
        }
      }
    }
  }
  return out;
}

}  // namespace

RevisitCheck checkRevisits(const ControlPointSelection& cps, const Trajectory& poses,
                           const Eigen::Isometry3d& T_enu_map,
                           const std::vector<std::optional<GnssPoint>>& gnss) {
  RevisitCheck out;
  const auto& pts = cps.points;
  const std::vector<double> path = arcLength(positionsOf(poses));
  std::vector<Eigen::Vector3d> aligned(pts.size()), targets(pts.size());
  std::vector<double> arc(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    aligned[i] = T_enu_map * pts[i].source;
    targets[i] = pts[i].target;
    arc[i] = path[pts[i].pose_index];
  }
  // Revisits where the SLAM puts the passes together, and where the targets do: an unclosed
  // loop holds one place twice, the passes metres apart in the SLAM's map.
  std::set<std::pair<std::size_t, std::size_t>> pairs = nearPairs(aligned, arc);
  for (const auto& p : nearPairs(targets, arc)) pairs.insert(p);
  for (const auto& [i, j] : pairs) {
    ++out.pairs;
    const Eigen::Vector3d slam = aligned[j] - aligned[i];
    const double d = ((pts[j].target - pts[i].target) - slam).norm();
    const bool slam_wrong = d > 0.5 + 3.0 * (pts[i].std_dev + pts[j].std_dev);
    if (slam_wrong) ++out.conflicting;
    out.worst = std::max(out.worst, d);
    const auto& gi = gnss[pts[i].pose_index];
    const auto& gj = gnss[pts[j].pose_index];
    if (!slam_wrong && gi && gj && gi->std_dev.allFinite() && gj->std_dev.allFinite() &&
        ((gj->position - gi->position) - slam).norm() >
            0.5 + 3.0 * (gi->stdDev3d() + gj->stdDev3d())) {
      ++out.gnss_conflicting;
    }
  }
  return out;
}

}  // namespace flexcloud
