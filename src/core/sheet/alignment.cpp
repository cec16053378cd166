#include "flexcloud/sheet/alignment.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <string>

#include "flexcloud/metrics.h"

namespace flexcloud {

Eigen::Isometry3d Similarity::rigid() const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = rotation;
  t.translation() = translation;
  return t;
}

namespace {
// Below this ratio of the second spread (singular value) to the first, the points lie on a line.
constexpr double kLine = 1e-3;
}  // namespace

Similarity umeyama(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                   const std::vector<double>& weights, bool with_scale) {
  if (src.size() != dst.size() || (!weights.empty() && weights.size() != src.size())) {
    throw Error("alignment: point and weight counts differ");
  }
  double w_sum = 0.0;
  std::size_t used = 0;
  Eigen::Vector3d mu_src = Eigen::Vector3d::Zero();
  Eigen::Vector3d mu_dst = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    if (!(w > 0.0)) continue;
    ++used;
    w_sum += w;
    mu_src += w * src[i];
    mu_dst += w * dst[i];
  }
  if (used < 3) {
    throw Error("alignment: " + std::to_string(used) +
                " usable pose/GNSS pairs, at least 3 are needed");
  }
  mu_src /= w_sum;
  mu_dst /= w_sum;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double var_src = 0.0;
  for (std::size_t i = 0; i < src.size(); ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    if (!(w > 0.0)) continue;
    const Eigen::Vector3d a = src[i] - mu_src;
    cov += w * (dst[i] - mu_dst) * a.transpose();
    var_src += w * a.squaredNorm();
  }
  cov /= w_sum;
  var_src /= w_sum;
  if (!(var_src > 1e-12)) throw Error("alignment: all trajectory positions coincide");

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d d = Eigen::Vector3d::Ones();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) d.z() = -1.0;
  Similarity out;
  const Eigen::Vector3d sv = svd.singularValues();
  out.rotation = svd.matrixU() * d.asDiagonal() * svd.matrixV().transpose();
  if (sv(1) <= kLine * sv(0)) {
    // A straight-line trajectory: the roll about the line is not observed (KITTI 04, 400 m
    // straight: the fit rolled it 11.5 degrees, and every point beside the road with it). The
    // line is turned onto the target's, and about it the source's up kept up.
    const Eigen::Vector3d a = svd.matrixV().col(0);
    const Eigen::Vector3d b = (out.rotation * a).normalized();
    const Eigen::Vector3d up = out.rotation * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d from = up - up.dot(b) * b, to = Eigen::Vector3d::UnitZ() - b.z() * b;
    if (from.norm() > 1e-9 && to.norm() > 1e-9) {
      const double angle = std::atan2(b.dot(from.cross(to)), from.dot(to));
      out.rotation = Eigen::AngleAxisd(angle, b).toRotationMatrix() * out.rotation;
    }
  }
  out.scale = with_scale ? svd.singularValues().dot(d) / var_src : 1.0;
  out.translation = mu_dst - out.scale * out.rotation * mu_src;
  return out;
}

Similarity robustRigidFit(const std::vector<Eigen::Vector3d>& src,
                          const std::vector<Eigen::Vector3d>& dst,
                          const std::vector<double>& weights, std::vector<double>* final_weights) {
  std::vector<double> w = weights;
  Similarity fit = umeyama(src, dst, w, false);
  for (int round = 0; round < 2; ++round) {
    std::vector<double> r(src.size());
    for (std::size_t i = 0; i < src.size(); ++i) {
      r[i] = (fit.rotation * src[i] + fit.translation - dst[i]).norm();
    }
    const double c = std::max(0.1, 3.0 * median(r));
    for (std::size_t i = 0; i < src.size(); ++i) {
      w[i] = weights[i] / (1.0 + (r[i] / c) * (r[i] / c));
    }
    fit = umeyama(src, dst, w, false);
  }
  if (final_weights != nullptr) *final_weights = w;
  return fit;
}

}  // namespace flexcloud
