// The fusion's hand-written Jacobians against ceres's automatic differentiation of the same
// residual functors, at random states (unit and non-unit quaternions, both signs of the
// rotation error's scalar part).
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "flexcloud/fusion/fusion_factors.h"

namespace flexcloud {
namespace {

struct Rng {
  std::mt19937 gen{7};
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(gen); }
  Eigen::Vector3d vec(double s) {
    return Eigen::Vector3d(uniform(-s, s), uniform(-s, s), uniform(-s, s));
  }
  Eigen::Quaterniond rotation() {
    Eigen::Quaterniond q(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    return q.normalized();
  }
};

/// Parameter blocks of the given sizes filled from the generator; quaternion blocks (size 4)
/// are unit rotations scaled by `norm`.
std::vector<std::vector<double>> randomBlocks(Rng& rng, const std::vector<int>& sizes,
                                              double norm) {
  std::vector<std::vector<double>> out;
  for (int n : sizes) {
    std::vector<double> b(n);
    if (n == 4) {
      const Eigen::Quaterniond q = rng.rotation();
      b = {norm * q.x(), norm * q.y(), norm * q.z(), norm * q.w()};
    } else {
      for (double& v : b) v = rng.uniform(-20, 20) / (n == 1 ? 100.0 : 1.0);
    }
    out.push_back(b);
  }
  return out;
}

/// Residuals and every Jacobian of both cost functions agree to 1e-9 (relative to their size).
void expectSame(const ceres::CostFunction& analytic, const ceres::CostFunction& automatic,
                const std::vector<std::vector<double>>& blocks) {
  const int m = analytic.num_residuals();
  ASSERT_EQ(m, automatic.num_residuals());
  const std::vector<int32_t>& sizes = analytic.parameter_block_sizes();
  ASSERT_EQ(sizes, automatic.parameter_block_sizes());
  std::vector<const double*> x;
  for (const auto& b : blocks) x.push_back(b.data());
  std::vector<double> r1(m), r2(m);
  std::vector<std::vector<double>> j1, j2;
  std::vector<double*> p1, p2;
  for (int n : sizes) {
    j1.emplace_back(m * n, 0.0);
    j2.emplace_back(m * n, 0.0);
  }
  for (std::size_t i = 0; i < sizes.size(); ++i)
    p1.push_back(j1[i].data()), p2.push_back(j2[i].data());
  ASSERT_TRUE(analytic.Evaluate(x.data(), r1.data(), p1.data()));
  ASSERT_TRUE(automatic.Evaluate(x.data(), r2.data(), p2.data()));
  for (int i = 0; i < m; ++i) EXPECT_NEAR(r1[i], r2[i], 1e-9 * (1 + std::abs(r2[i])));
  for (std::size_t b = 0; b < sizes.size(); ++b) {
    for (std::size_t k = 0; k < j1[b].size(); ++k) {
      EXPECT_NEAR(j1[b][k], j2[b][k], 1e-9 * (1 + std::abs(j2[b][k])))
          << "block " << b << " entry " << k;
    }
  }
}

TEST(FusionFactors, OdometryJacobianIsAutodiffs) {
  Rng rng;
  int negative = 0;
  for (int trial = 0; trial < 200; ++trial) {
    OdometryFactor f{rng.vec(10), rng.rotation(), rng.uniform(0.1, 30), rng.uniform(0.01, 1),
                     rng.uniform(1e-4, 1e-2)};
    const double norm = trial % 4 == 0 ? rng.uniform(0.7, 1.3) : 1.0;
    const auto blocks = randomBlocks(rng, {4, 3, 3, 1, 4, 3}, norm);
    const Eigen::Quaterniond qa(blocks[0][3], blocks[0][0], blocks[0][1], blocks[0][2]);
    const Eigen::Quaterniond qb(blocks[4][3], blocks[4][0], blocks[4][1], blocks[4][2]);
    negative += (f.dq.conjugate() * qa.conjugate() * qb).w() < 0;
    const OdometryCost analytic(f);
    const ceres::AutoDiffCostFunction<OdometryFactor, 6, 4, 3, 3, 1, 4, 3> automatic(
        new OdometryFactor(f));
    expectSame(analytic, automatic, blocks);
  }
  EXPECT_GT(negative, 20);  // both branches of the sign were compared
  EXPECT_LT(negative, 180);
}

TEST(FusionFactors, DriftJacobianIsAutodiffs) {
  Rng rng;
  for (int trial = 0; trial < 20; ++trial) {
    const DriftFactor f{rng.uniform(1e-6, 1e-3), rng.uniform(1e-5, 1e-2)};
    const DriftCost analytic(f);
    const ceres::AutoDiffCostFunction<DriftFactor, 4, 3, 1, 3, 1> automatic(new DriftFactor(f));
    expectSame(analytic, automatic, randomBlocks(rng, {3, 1, 3, 1}, 1.0));
  }
}

TEST(FusionFactors, GnssJacobianIsAutodiffs) {
  Rng rng;
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d sigma(rng.uniform(0.01, 3), rng.uniform(0.01, 3), rng.uniform(0.01, 5));
    GnssFactor f{rng.vec(30), rng.vec(2), rng.vec(20), rng.vec(1000), &sigma};
    f.axes = rng.rotation().toRotationMatrix().leftCols<2>();
    const double norm = trial % 4 == 0 ? rng.uniform(0.7, 1.3) : 1.0;
    const GnssCost analytic(f);
    const ceres::AutoDiffCostFunction<GnssFactor, 3, 4, 3, 1, 1, 2> automatic(new GnssFactor(f));
    expectSame(analytic, automatic, randomBlocks(rng, {4, 3, 1, 1, 2}, norm));
  }
}

TEST(FusionFactors, RotationJacobianMatchesAFiniteDifference) {
  // An independent check of the rotation's derivative: central differences of q * v.
  Rng rng;
  const Eigen::Quaterniond q = rng.rotation();
  const Eigen::Vector3d v = rng.vec(5);
  const Eigen::Matrix<double, 3, 4> j = rotationJacobian(q, v);
  const double h = 1e-6;
  for (int c = 0; c < 4; ++c) {
    Eigen::Vector4d plus = q.coeffs(), minus = q.coeffs();
    plus(c) += h, minus(c) -= h;
    const Eigen::Vector3d d =
        (Eigen::Quaterniond(plus) * v - Eigen::Quaterniond(minus) * v) / (2 * h);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(j(i, c), d(i), 1e-6);
  }
}

}  // namespace
}  // namespace flexcloud
