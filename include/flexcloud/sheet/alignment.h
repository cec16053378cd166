#pragma once
// Rigid alignment of the SLAM trajectory to the GNSS (Umeyama, 1991).

#include <vector>

#include "flexcloud/types.h"

namespace flexcloud {

/// dst = scale * rotation * src + translation.
struct Similarity {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;
  Eigen::Isometry3d rigid() const;
};

/// The similarity (with_scale) or rigid transform (scale fixed to 1) minimising
/// sum_i w_i |dst_i - (s R src_i + t)|^2. weights may be empty (all 1). Throws Error when fewer
/// than 3 points have positive weight or when all of them coincide.
Similarity umeyama(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                   const std::vector<double>& weights, bool with_scale);

/// The rigid umeyama() fit reweighted twice by a Cauchy weight of each pair's residual (scale
/// three times their median, at least 0.1 m), so that outliers pull less. `weights` are the
/// pairs' own weights (not empty). The weights of the last fit are left in `final_weights`
/// when given.
Similarity robustRigidFit(const std::vector<Eigen::Vector3d>& src,
                          const std::vector<Eigen::Vector3d>& dst,
                          const std::vector<double>& weights,
                          std::vector<double>* final_weights = nullptr);

}  // namespace flexcloud
