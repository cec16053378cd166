// The fusion's result: its fixes' outcomes, counts and poses.
#include "flexcloud/metrics.h"
#include "fusion_graph.h"

namespace flexcloud {

Eigen::Vector3d FixOutcome::weighedSigma() const {
  const Eigen::Vector3d j2 = slam_jitter.cwiseProduct(slam_jitter);
  return (std_dev.cwiseProduct(std_dev) + j2 + Eigen::Vector3d::Constant(slam_gap * slam_gap))
      .cwiseSqrt();
}

bool apartInHeightAlone(const Eigen::Vector3d& error, const Eigen::Vector3d& sigma) {
  if (!error.allFinite() || !sigma.allFinite()) return false;
  return error.head<2>().norm() <= kHeightApart * sigma.x() &&
         std::abs(error.z()) > kHeightApart * sigma.z();
}

namespace fusion_graph {

Eigen::Isometry3d Fusion::keyframePose(const Keyframe& k) const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::Quaterniond(k.q[3], k.q[0], k.q[1], k.q[2]).normalized().toRotationMatrix();
  t.translation() = Vec3(k.p[0], k.p[1], k.p[2]);
  return t;
}

void Fusion::collect() {
  std::vector<double> sigmas;
  for (const auto& f : fixes_) {
    FixOutcome& o = out_.fixes[f.input];
    o.error = -residualOf(f);  // the factor's residual is the fused antenna less the fix
    o.residual = o.error.norm();
    o.slam_jitter = f.jitter;
    o.slam_gap = f.gap;
    o.std_dev = ownSigma(gnss_[f.input].std_dev, unknown_h_, unknown_v_);
    o.weight = weightOf(f);
    o.verdict = o.weight < kRejectWeight ? FixVerdict::kOutlier : FixVerdict::kUsed;
    o.height_left_out = f.level_only && o.verdict == FixVerdict::kUsed;
    out_.heights_left_out += o.height_left_out ? 1 : 0;
    if (o.verdict == FixVerdict::kUsed) sigmas.push_back(f.sigma.x());
  }
  for (const auto& o : out_.fixes) {
    switch (o.verdict) {
      case FixVerdict::kUsed:
        ++out_.used;
        break;
      case FixVerdict::kOutlier:
        ++out_.outliers;
        break;
      case FixVerdict::kAboveThreshold:
        ++out_.above_threshold;
        break;
      case FixVerdict::kExcluded:
        ++out_.excluded;
        break;
      case FixVerdict::kOutsidePoses:
        ++out_.outside;
        break;
    }
  }
  if (!sigmas.empty()) out_.median_std_h = median(std::move(sigmas));
  if (unknown_h_ == kUnknownStdStart) {
    out_.estimated_std_h = out_.estimated_std_v = std::numeric_limits<double>::quiet_NaN();
  }
  out_.time_offset = shift_ + dt_;
  out_.antenna_offset = Eigen::Vector2d(lever_[0], lever_[1]);
  out_.antenna_offset_estimated = estimate_lever_;
  out_.time_offset_estimated = clock_.observable;
  out_.time_offset_from_speed = out_.clock.speed.offset;
  out_.time_offset_speed_sigma = out_.clock.speed.sigma;
  out_.time_offset_sigma = offset_sigma_;
  fusedPoses();
}

void Fusion::fusedPoses() {
  out_.poses.resize(poses_.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < poses_.size(); ++i) {
    while (k + 1 < keyframes_.size() && keyframes_[k + 1].pose <= i) ++k;
    const Keyframe& key = keyframes_[k];
    Eigen::Isometry3d rel = key.slam.inverse() * isometry(poses_[i]);
    rel.translation() *= 1.0 + key.s;
    const Eigen::Isometry3d t = keyframePose(key) * rel;
    // Where the fusion estimated the antenna's offset, the pose is the antenna's (with the
    // body's orientation): with no lever arm given, the antenna is the poses' origin.
    Vec3 level = t.linear() * Vec3(lever_[0], lever_[1], 0.0);
    level.z() = 0.0;
    Pose& p = out_.poses[i];
    p.stamp = poses_[i].stamp;
    p.position = t.translation() + level + origin_;
    p.orientation = Eigen::Quaterniond(t.linear()).normalized();
  }
}

}  // namespace fusion_graph
}  // namespace flexcloud
