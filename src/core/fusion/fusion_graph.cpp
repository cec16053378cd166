// The fusion graph's helpers: the SLAM noise model, fix classes, SLAM poses between stamps and
// keyframes.
#include "fusion_graph.h"

#include <algorithm>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/metrics.h"

namespace flexcloud {
namespace fusion_graph {

Noise noiseOf(const FusionOptions& p, double factor) {
  const double per_sqrt_km = factor / std::sqrt(1000.0);
  return {p.slam_rotation_noise * kDeg * per_sqrt_km, p.slam_translation_noise * per_sqrt_km,
          p.slam_drift_noise * kDeg / 1000.0 * per_sqrt_km,
          p.slam_scale_noise / 100.0 * per_sqrt_km};
}

int classOf(const Eigen::Vector3d& reported) {
  const double h = reported.head<2>().norm() / std::sqrt(2.0);
  int c = 0;
  while (c < kClasses - 1 && !(h < kClassBounds[c])) ++c;
  return c;
}

Eigen::Isometry3d isometry(const Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = p.orientation.toRotationMatrix();
  t.translation() = p.position;
  return t;
}

Eigen::Isometry3d slamAt(const Trajectory& poses, double t) {
  const auto it = std::lower_bound(poses.begin(), poses.end(), t,
                                   [](const Pose& p, double s) { return p.stamp < s; });
  if (it == poses.begin()) return isometry(poses.front());
  if (it == poses.end()) return isometry(poses.back());
  const Pose& b = *it;
  const Pose& a = *(it - 1);
  const double f = (t - a.stamp) / std::max(1e-12, b.stamp - a.stamp);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = a.orientation.slerp(f, b.orientation).toRotationMatrix();
  out.translation() = a.position + f * (b.position - a.position);
  return out;
}

double gapSpread(const Trajectory& poses, double t) {
  const auto it = std::lower_bound(poses.begin(), poses.end(), t,
                                   [](const Pose& p, double s) { return p.stamp < s; });
  if (it == poses.begin() || it == poses.end()) return 0.0;
  const Pose& b = *it;
  const Pose& a = *(it - 1);
  // A change of speed at up to kGapAccel moves the vehicle from the interpolated place by at
  // most kGapAccel (t - ta) (tb - t) / 2, and never further than the poses lie apart.
  const double bound = kGapAccel * (t - a.stamp) * (b.stamp - t) / 2.0;
  return 0.5 * std::min(bound, (b.position - a.position).norm());
}

std::vector<std::size_t> chooseKeyframes(const Trajectory& poses, double spacing) {
  const std::vector<double> arc = arcLength(positionsOf(poses));
  spacing = std::max(spacing, arc.back() / static_cast<double>(kMaxKeyframes));
  std::vector<std::size_t> out{0};
  for (std::size_t i = 1; i + 1 < poses.size(); ++i) {
    if (arc[i] - arc[out.back()] >= spacing) out.push_back(i);
  }
  if (poses.size() > 1) out.push_back(poses.size() - 1);
  return out;
}

}  // namespace fusion_graph
}  // namespace flexcloud
