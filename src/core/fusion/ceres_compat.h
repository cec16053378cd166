#pragma once
// The quaternion blocks of the fusion's Ceres problem on every Ceres it builds with: Manifolds
// from Ceres 2.1 on (2.2 removed LocalParameterization), LocalParameterization before it (1.14
// on Ubuntu 20.04 and Debian 11). Private to the core.

#include <ceres/ceres.h>
#include <ceres/version.h>

namespace flexcloud {
namespace fusion_graph {

#if CERES_VERSION_MAJOR > 2 || (CERES_VERSION_MAJOR == 2 && CERES_VERSION_MINOR >= 1)
using QuaternionBlock = ceres::EigenQuaternionManifold;
/// The problem leaves the block's shape (the fusion's own member) to its owner.
inline void keepBlockShapes(ceres::Problem::Options& options) {
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
}
#else
using QuaternionBlock = ceres::EigenQuaternionParameterization;
inline void keepBlockShapes(ceres::Problem::Options& options) {
  options.local_parameterization_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
}
#endif

}  // namespace fusion_graph
}  // namespace flexcloud
