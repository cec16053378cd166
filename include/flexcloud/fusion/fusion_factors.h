#pragma once
/// The fusion's residuals (fusion.cpp): each as a templated functor, which says what it measures
/// and evaluates it, and as a cost function with its Jacobians written out, which the solver
/// uses (on a one-hour drive Ceres's Jacobian time per iteration halved against automatic
/// differentiation of the same functors, which the unit tests compare them with).
/// Quaternions are stored x y z w (Eigen's order) and rotate a vector as Eigen does.

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace flexcloud {

template <typename T>
using Vec3T = Eigen::Matrix<T, 3, 1>;

/// SLAM motion between keyframes a and b, with a's drift state: the rotation error grows at
/// rate w (rad/m) and the translation is off by the scale error s.
struct OdometryFactor {
  Eigen::Vector3d dp;
  Eigen::Quaterniond dq;
  double length, sigma_t, sigma_r;

  template <typename T>
  bool operator()(const T* qa, const T* pa, const T* wa, const T* sa, const T* qb, const T* pb,
                  T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> Qa(qa), Qb(qb);
    const Eigen::Map<const Vec3T<T>> Pa(pa), Pb(pb), Wa(wa);
    const Vec3T<T> rel = Qa.conjugate() * (Pb - Pa);
    const Vec3T<T> rt = (rel - (T(1) + sa[0]) * dp.cast<T>()) / T(sigma_t);
    const Eigen::Quaternion<T> e = dq.cast<T>().conjugate() * Qa.conjugate() * Qb;
    Vec3T<T> angle = T(2) * e.vec();
    if (e.w() < T(0)) angle = -angle;
    const Vec3T<T> rr = (angle - Wa * T(length)) / T(sigma_r);
    for (int i = 0; i < 3; ++i) r[i] = rt[i], r[3 + i] = rr[i];
    return true;
  }
};

/// The drift state changes slowly along the path.
struct DriftFactor {
  double sigma_w, sigma_s;
  template <typename T>
  bool operator()(const T* wa, const T* sa, const T* wb, const T* sb, T* r) const {
    for (int i = 0; i < 3; ++i) r[i] = (wb[i] - wa[i]) / T(sigma_w);
    r[3] = (sb[0] - sa[0]) / T(sigma_s);
    return true;
  }
};

/// A fix: the antenna of the pose at the fix's stamp, reached from keyframe a by the SLAM's
/// motion (scaled by a's scale error), the lever arm, and the clock offset dt times the
/// velocity; where no lever arm was given, the offset the fusion estimates along the body's
/// forward and left axes, on the horizontal position alone (the tilt it would act on in height
/// is the SLAM's, not known well enough to take a height from).
struct GnssFactor {
  /// SLAM translation from keyframe a to the fix's stamp, in a's frame.
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  /// Lever arm rotated into a's frame at the fix's stamp.
  Eigen::Vector3d antenna = Eigen::Vector3d::Zero();
  /// SLAM velocity at the fix's stamp, in a's frame, m/s.
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d fix = Eigen::Vector3d::Zero();
  const Eigen::Vector3d* sigma = nullptr;  ///< the std-dev it is weighted with now
  /// The body's forward and left axes at the fix's stamp in a's frame: the estimated lever
  /// arm (body x, y) reaches the antenna along them.
  Eigen::Matrix<double, 3, 2> axes = Eigen::Matrix<double, 3, 2>::Zero();

  /// The vector in keyframe a's frame that reaches the antenna from a's position, the
  /// estimated offset aside.
  template <typename T>
  Vec3T<T> local(const T* sa, const T* dt) const {
    return (T(1) + sa[0]) * offset.cast<T>() + antenna.cast<T>() + velocity.cast<T>() * dt[0];
  }

  /// The estimated offset in a's frame.
  template <typename T>
  Vec3T<T> reach(const T* lever) const {
    return axes.cast<T>() * Eigen::Matrix<T, 2, 1>(lever[0], lever[1]);
  }

  template <typename T>
  bool operator()(const T* qa, const T* pa, const T* sa, const T* dt, const T* lever, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> Qa(qa);
    const Eigen::Map<const Vec3T<T>> Pa(pa);
    Vec3T<T> level = Qa * reach(lever);
    level.z() = T(0);
    const Vec3T<T> at = Pa + Qa * local(sa, dt) + level;
    for (int i = 0; i < 3; ++i) r[i] = (at[i] - T(fix[i])) / T((*sigma)[i]);
    return true;
  }
};

/// d(q * v)/dq (3 x 4, columns x y z w) for the rotation as Eigen computes it,
/// v + 2w (u x v) + 2 u x (u x v) with u the vector part: exact for any q, unit or not.
Eigen::Matrix<double, 3, 4> rotationJacobian(const Eigen::Quaterniond& q, const Eigen::Vector3d& v);

/// The matrix of a x b as a linear map of b (4 x 4, x y z w order) and as one of a.
Eigen::Matrix4d leftProductMatrix(const Eigen::Quaterniond& a);
Eigen::Matrix4d rightProductMatrix(const Eigen::Quaterniond& b);

class OdometryCost : public ceres::SizedCostFunction<6, 4, 3, 3, 1, 4, 3> {
 public:
  explicit OdometryCost(const OdometryFactor& f) : f_(f) {}
  bool Evaluate(double const* const* x, double* r, double** jacobians) const override;

 private:
  OdometryFactor f_;
};

class DriftCost : public ceres::SizedCostFunction<4, 3, 1, 3, 1> {
 public:
  explicit DriftCost(const DriftFactor& f) : f_(f) {}
  bool Evaluate(double const* const* x, double* r, double** jacobians) const override;

 private:
  DriftFactor f_;
};

class GnssCost : public ceres::SizedCostFunction<3, 4, 3, 1, 1, 2> {
 public:
  explicit GnssCost(const GnssFactor& f) : f_(f) {}
  bool Evaluate(double const* const* x, double* r, double** jacobians) const override;

 private:
  GnssFactor f_;
};

/// A fix's horizontal part alone (GnssCost's first two rows): for a fix whose height is left
/// out.
class GnssLevelCost : public ceres::SizedCostFunction<2, 4, 3, 1, 1, 2> {
 public:
  explicit GnssLevelCost(const GnssFactor& f) : whole_(f) {}
  bool Evaluate(double const* const* x, double* r, double** jacobians) const override;

 private:
  GnssCost whole_;
};

}  // namespace flexcloud
