// The fusion's clock offset: from the speed profiles, restamped to the millisecond, its 1-sigma.
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <optional>

#include "fusion_graph.h"

namespace flexcloud {
namespace fusion_graph {

void Fusion::estimateClock() {
  std::vector<GnssPoint> taking_part;
  for (const auto& f : fixes_) taking_part.push_back(gnss_[f.input]);
  clock_ = estimateClockOffset(poses_, taking_part, options_.max_time_offset);
  shift_ = clock_.observable ? clock_.offset : 0.0;
  dt_ = 0.0;
}

double Fusion::offsetSigma(ceres::Problem& problem) {
  ceres::Problem::EvaluateOptions eval;
  std::vector<double*> blocks;
  problem.GetParameterBlocks(&blocks);
  std::rotate(blocks.begin(), std::find(blocks.begin(), blocks.end(), &dt_), blocks.end());
  eval.parameter_blocks = blocks;  // the offset last
  double cost = 0.0;
  ceres::CRSMatrix crs;
  if (!problem.Evaluate(eval, &cost, nullptr, nullptr, &crs)) return kInf;
  const int n = crs.num_cols;
  std::vector<Eigen::Triplet<double>> entries;
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
      entries.emplace_back(r, crs.cols[k], crs.values[k]);
    }
  }
  Eigen::SparseMatrix<double> j(crs.num_rows, n);
  j.setFromTriplets(entries.begin(), entries.end());
  const Eigen::SparseMatrix<double> h = j.transpose() * j;
  const Eigen::SparseMatrix<double> hxx = h.topLeftCorner(n - 1, n - 1);
  const Eigen::VectorXd hxd = h.block(0, n - 1, n - 1, 1);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(hxx);
  if (ldlt.info() != Eigen::Success) return kInf;
  const double schur = h.coeff(n - 1, n - 1) - hxd.dot(ldlt.solve(hxd));
  if (!(schur > 0.0)) return kInf;
  const double dof = static_cast<double>(crs.num_rows - n);
  const double spread = dof > 0.0 ? std::max(1.0, 2.0 * cost / dof) : 1.0;
  return std::sqrt(spread / schur);
}

void Fusion::restamp() {
  for (int round = 0; round < kRestampRounds; ++round) {
    if (!clock_.observable || !(std::abs(dt_) > kRestampTolerance)) break;
    solveRestampedAt(shift_ + dt_);
  }
}

void Fusion::solveRestampedAt(double shift) {
  shift_ = shift;
  dt_ = 0.0;
  selectFixes();
  prepareFixes(unknown_h_, unknown_v_);
  const auto full = makeProblem(1);
  solveAt(*full, 0.0, 10);
}

void Fusion::holdClockWhereTheSpeedsDisagree() {
  out_.time_offset_from_positions = shift_ + dt_;
  const std::optional<double> held = heldClockOffset(shift_ + dt_, clock_);
  if (!held) return;
  out_.time_offset_held = true;
  solveRestampedAt(*held);
}

}  // namespace fusion_graph
}  // namespace flexcloud
