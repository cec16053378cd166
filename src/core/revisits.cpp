#include "revisits.h"

#include <algorithm>

#include "cell_hash.h"

namespace flexcloud {

RevisitCheck checkRevisits(const ControlPointSelection& cps, const Trajectory& poses,
                           const Eigen::Isometry3d& T_enu_map,
                           const std::vector<std::optional<GnssPoint>>& gnss) {
  constexpr double kRadius = 5.0, kOtherPass = 50.0;
  RevisitCheck out;
  const auto& pts = cps.points;
  const std::vector<double> arc = arcLength(positionsOf(poses));
  CellMap<std::vector<std::size_t>> cells;
  std::vector<Eigen::Vector3d> aligned(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    aligned[i] = T_enu_map * pts[i].source;
    cells[cellOf(aligned[i], kRadius)].push_back(i);
  }
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3i key = cellOf(aligned[i], kRadius);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find(key + Eigen::Vector3i(dx, dy, dz));
          if (it == cells.end()) continue;
          for (std::size_t j : it->second) {
            if (j <= i || (aligned[j] - aligned[i]).norm() > kRadius ||
                std::abs(arc[pts[j].pose_index] - arc[pts[i].pose_index]) < kOtherPass) {
              continue;
            }
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
        }
      }
    }
  }
  return out;
}

}  // namespace flexcloud
