#include "flexcloud/sim/truth_metrics.h"

namespace flexcloud::sim {

MapTruthErrors mapTruthErrors(const SimMap& map,
                              const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& warp) {
  ErrorAccumulator all, near, mid, far;
  for (std::size_t i = 0; i < map.slam.size(); ++i) {
    // The SLAM map is stored in float32, as a SLAM system writes it.
    const Eigen::Vector3d p = map.slam[i].cast<float>().cast<double>();
    const double e = (warp(p) - map.truth[i]).norm();
    all.add(e);
    const float d = map.lateral[i];
    (d < 5.0f ? near : d < 15.0f ? mid : far).add(e);
  }
  return {all.stats(), near.stats(), mid.stats(), far.stats()};
}

MapTruthErrors mapTruthErrors(const SimMap& map, const RubberSheet& sheet) {
  return mapTruthErrors(map, [&](const Eigen::Vector3d& p) { return sheet.transform(p); });
}

ErrorStats trajectoryTruthError(const Trajectory& estimate, const Trajectory& truth) {
  ErrorAccumulator acc;
  for (std::size_t i = 0; i < estimate.size() && i < truth.size(); ++i) {
    acc.add((estimate[i].position - truth[i].position).norm());
  }
  return acc.stats();
}

}  // namespace flexcloud::sim
