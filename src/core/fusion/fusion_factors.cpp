#include "flexcloud/fusion/fusion_factors.h"

#include <algorithm>

namespace flexcloud {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

/// A ceres Jacobian block (row-major R x C) as an Eigen matrix.
template <int R, int C>
using JacobianMap =
    Eigen::Map<Eigen::Matrix<double, R, C, (C == 1 ? Eigen::ColMajor : Eigen::RowMajor)>>;

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// The linear map v -> q * v as Eigen computes it: I + 2w [u]x + 2 [u]x^2.
Mat3 rotationMatrix(const Eigen::Quaterniond& q) {
  const Mat3 u = skew(q.vec());
  return Mat3::Identity() + 2.0 * q.w() * u + 2.0 * u * u;
}

/// d(conjugate(q))/dq in x y z w order.
Eigen::Matrix4d conjugation() { return Eigen::Vector4d(-1, -1, -1, 1).asDiagonal(); }

Eigen::Quaterniond quaternion(const double* x) {
  return Eigen::Quaterniond(x[3], x[0], x[1], x[2]);
}
Vec3 vec3(const double* x) { return Vec3(x[0], x[1], x[2]); }

}  // namespace

Eigen::Matrix<double, 3, 4> rotationJacobian(const Eigen::Quaterniond& q, const Vec3& v) {
  const Vec3 u = q.vec();
  Eigen::Matrix<double, 3, 4> j;
  j.leftCols<3>() = -2.0 * q.w() * skew(v) - 2.0 * skew(u.cross(v)) - 2.0 * skew(u) * skew(v);
  j.col(3) = 2.0 * u.cross(v);
  return j;
}

Eigen::Matrix4d leftProductMatrix(const Eigen::Quaterniond& a) {
  Eigen::Matrix4d m;
  m.topLeftCorner<3, 3>() = a.w() * Mat3::Identity() + skew(a.vec());
  m.topRightCorner<3, 1>() = a.vec();
  m.bottomLeftCorner<1, 3>() = -a.vec().transpose();
  m(3, 3) = a.w();
  return m;
}

Eigen::Matrix4d rightProductMatrix(const Eigen::Quaterniond& b) {
  Eigen::Matrix4d m;
  m.topLeftCorner<3, 3>() = b.w() * Mat3::Identity() - skew(b.vec());
  m.topRightCorner<3, 1>() = b.vec();
  m.bottomLeftCorner<1, 3>() = -b.vec().transpose();
  m(3, 3) = b.w();
  return m;
}

bool OdometryCost::Evaluate(double const* const* x, double* r, double** jacobians) const {
  f_(x[0], x[1], x[2], x[3], x[4], x[5], r);
  if (jacobians == nullptr) return true;
  const Eigen::Quaterniond qa = quaternion(x[0]), qb = quaternion(x[4]);
  const Eigen::Quaterniond qa_inv = qa.conjugate();
  const Eigen::Quaterniond a = f_.dq.conjugate() * qa_inv;  // e = a * qb
  const double sign = (a * qb).w() < 0.0 ? -1.0 : 1.0;
  const double kt = 1.0 / f_.sigma_t, kr = 2.0 * sign / f_.sigma_r;
  const Mat3 back = rotationMatrix(qa_inv);
  if (jacobians[0] != nullptr) {  // qa
    JacobianMap<6, 4> j(jacobians[0]);
    j.topRows<3>() = kt * rotationJacobian(qa_inv, vec3(x[5]) - vec3(x[1])) * conjugation();
    j.bottomRows<3>() =
        kr * (rightProductMatrix(qb) * leftProductMatrix(f_.dq.conjugate()) * conjugation())
                 .topRows<3>();
  }
  if (jacobians[1] != nullptr) {  // pa
    JacobianMap<6, 3> j(jacobians[1]);
    j.topRows<3>() = -kt * back;
    j.bottomRows<3>().setZero();
  }
  if (jacobians[2] != nullptr) {  // wa
    JacobianMap<6, 3> j(jacobians[2]);
    j.topRows<3>().setZero();
    j.bottomRows<3>() = -f_.length / f_.sigma_r * Mat3::Identity();
  }
  if (jacobians[3] != nullptr) {  // sa
    JacobianMap<6, 1> j(jacobians[3]);
    j.head<3>() = -kt * f_.dp;
    j.tail<3>().setZero();
  }
  if (jacobians[4] != nullptr) {  // qb
    JacobianMap<6, 4> j(jacobians[4]);
    j.topRows<3>().setZero();
    j.bottomRows<3>() = kr * leftProductMatrix(a).topRows<3>();
  }
  if (jacobians[5] != nullptr) {  // pb
    JacobianMap<6, 3> j(jacobians[5]);
    j.topRows<3>() = kt * back;
    j.bottomRows<3>().setZero();
  }
  return true;
}

bool DriftCost::Evaluate(double const* const* x, double* r, double** jacobians) const {
  f_(x[0], x[1], x[2], x[3], r);
  if (jacobians == nullptr) return true;
  for (int side = 0; side < 2; ++side) {
    const double sign = side == 0 ? -1.0 : 1.0;
    if (jacobians[2 * side] != nullptr) {  // w
      JacobianMap<4, 3> j(jacobians[2 * side]);
      j.setZero();
      j.topRows<3>() = sign / f_.sigma_w * Mat3::Identity();
    }
    if (jacobians[2 * side + 1] != nullptr) {  // s
      JacobianMap<4, 1> j(jacobians[2 * side + 1]);
      j.setZero();
      j(3) = sign / f_.sigma_s;
    }
  }
  return true;
}

bool GnssCost::Evaluate(double const* const* x, double* r, double** jacobians) const {
  f_(x[0], x[1], x[2], x[3], x[4], r);
  if (jacobians == nullptr) return true;
  const Eigen::Quaterniond q = quaternion(x[0]);
  const Eigen::DiagonalMatrix<double, 3> k(f_.sigma->cwiseInverse());
  const Mat3 rot = rotationMatrix(q);
  if (jacobians[0] != nullptr) {
    JacobianMap<3, 4> j(jacobians[0]);
    Eigen::Matrix<double, 3, 4> level = rotationJacobian(q, f_.reach(x[4]));
    level.row(2).setZero();
    j = k * (rotationJacobian(q, f_.local(x[2], x[3])) + level);
  }
  if (jacobians[1] != nullptr) {
    JacobianMap<3, 3> j(jacobians[1]);
    j = Mat3(k);
  }
  if (jacobians[2] != nullptr) {
    JacobianMap<3, 1> j(jacobians[2]);
    j = k * (rot * f_.offset);
  }
  if (jacobians[3] != nullptr) {
    JacobianMap<3, 1> j(jacobians[3]);
    j = k * (rot * f_.velocity);
  }
  if (jacobians[4] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 3, 2, Eigen::RowMajor>> j(jacobians[4]);
    Eigen::Matrix<double, 3, 2> level = rot * f_.axes;
    level.row(2).setZero();
    j = k * level;
  }
  return true;
}

bool GnssLevelCost::Evaluate(double const* const* x, double* r, double** jacobians) const {
  constexpr int kSizes[5] = {4, 3, 1, 1, 2};
  double whole_r[3];
  double j0[12], j1[9], j2[3], j3[3], j4[6];
  double* whole_j[5] = {j0, j1, j2, j3, j4};
  if (jacobians != nullptr) {
    for (int b = 0; b < 5; ++b) whole_j[b] = jacobians[b] != nullptr ? whole_j[b] : nullptr;
  }
  if (!whole_.Evaluate(x, whole_r, jacobians != nullptr ? whole_j : nullptr)) return false;
  r[0] = whole_r[0], r[1] = whole_r[1];
  if (jacobians == nullptr) return true;
  for (int b = 0; b < 5; ++b) {  // row-major: the first two rows are the first 2 * size values
    if (jacobians[b] != nullptr) std::copy(whole_j[b], whole_j[b] + 2 * kSizes[b], jacobians[b]);
  }
  return true;
}

}  // namespace flexcloud
