#include "sheet/sheet_fit.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <map>
#include <numeric>

#include "sheet/tet_locator.h"

namespace flexcloud {
namespace {

constexpr double kRidge = 1e-2;       // keeps a target that few poses see near where it was
constexpr double kConsistent = 1e-6;  // m: the barycentric image must be the sheet's own
constexpr double kOwnPose = 10.0;

/// The control point (index into cps.points) each point beside belongs to; -1 for none.
std::vector<int> ownersOf(const ControlPointSelection& cps, const std::vector<PointPair>& beside) {
  std::map<std::size_t, int> by_pose;
  for (std::size_t k = 0; k < cps.points.size(); ++k) {
    by_pose[cps.points[k].pose_index] = static_cast<int>(k);
  }
  std::vector<int> owner;
  for (const auto& b : beside) {
    const auto it = by_pose.find(b.pose_index);
    owner.push_back(it == by_pose.end() ? -1 : it->second);
  }
  return owner;
}

/// The control point (index into cps.points) each of the sheet's vertices moves with; -1 for
/// the cuboid's corners. The sheet lists its sources in the order they were given: control
/// points, points beside, corners. Where it merged a source into an earlier one (within 1 mm)
/// that order no longer tells which is which: every vertex is -1 then, and nothing is fitted.
std::vector<int> vertexGroups(const RubberSheet& sheet, const ControlPointSelection& cps,
                              const std::vector<PointPair>& beside) {
  std::vector<int> given(cps.points.size());
  std::iota(given.begin(), given.end(), 0);
  const std::vector<int> owner = ownersOf(cps, beside);
  given.insert(given.end(), owner.begin(), owner.end());
  std::vector<int> groups(sheet.sources().size(), -1);
  const std::size_t corners = 8;
  if (sheet.merged() == 0 && sheet.sources().size() == given.size() + corners) {
    std::copy(given.begin(), given.end(), groups.begin());
  }
  return groups;
}

struct Rows {
  std::vector<Eigen::Triplet<double>> a;
  std::vector<Eigen::Vector3d> b;
};

/// One row per pose inside the sheet: the weights of its tetrahedron's groups and what is left
/// between its fused pose and its image.
Rows poseRows(const RubberSheet& sheet, const std::vector<int>& groups, const Trajectory& poses,
              const Trajectory& fused, const std::vector<double>& weight_of_pose) {
  Rows rows;
  const auto& tets = sheet.locatorTets();
  int hint = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Vector3d& x = poses[i].position;
    const RubberSheet::Location loc = sheet.locateFrom(x, hint);
    if (loc.outside) continue;
    hint = loc.tet;
    const LocatorTet& t = tets[static_cast<std::size_t>(loc.tet)];
    const std::array<int, 4>& vertices = sheet.tetrahedra()[static_cast<std::size_t>(loc.tet)];
    const Eigen::Vector3d l = t.bary * (x - t.v0);
    const double lambda[4] = {1.0 - l.sum(), l.x(), l.y(), l.z()};
    const Eigen::Vector3d image = RubberSheet::apply(sheet.affineAt(loc), x);
    Eigen::Vector3d again = Eigen::Vector3d::Zero();
    std::map<int, double> weight;
    for (int c = 0; c < 4; ++c) {
      const auto v = static_cast<std::size_t>(vertices[static_cast<std::size_t>(c)]);
      again += lambda[c] * sheet.targets()[v];
      if (groups[v] >= 0) weight[groups[v]] += lambda[c];
    }
    // A sliver carries a neighbour's transform: its own weights do not describe the image.
    if ((again - image).norm() > kConsistent || weight.empty()) continue;
    const int row = static_cast<int>(rows.b.size());
    const double k = weight_of_pose[i];
    for (const auto& [g, w] : weight) rows.a.emplace_back(row, g, k * w);
    rows.b.push_back(k * (fused[i].position - image));
  }
  return rows;
}

}  // namespace

std::vector<Eigen::Vector3d> fitSheetTargets(const RubberSheet& sheet,
                                             const ControlPointSelection& cps,
                                             const std::vector<PointPair>& beside,
                                             const Trajectory& poses, const Trajectory& fused) {
  const auto n = static_cast<int>(cps.points.size());
  std::vector<Eigen::Vector3d> move(cps.points.size(), Eigen::Vector3d::Zero());
  const std::vector<int> groups = vertexGroups(sheet, cps, beside);
  // A control point's own pose weighs as much as kOwnPose others: the sheet passes through its
  // control points (to a few millimetres) and fits the poses between them. Weighed as one, a
  // control point where the fused trajectory turns or breaks was moved off it by the poses
  // around (KITTI 09 with RTK GNSS: 0.21 m at its last control points).
  std::vector<double> weight_of_pose(poses.size(), 1.0);
  for (const auto& cp : cps.points) {
    if (cp.pose_index < poses.size()) weight_of_pose[cp.pose_index] = kOwnPose;
  }
  const Rows rows = poseRows(sheet, groups, poses, fused, weight_of_pose);
  if (rows.b.empty()) return move;
  Eigen::SparseMatrix<double> a(static_cast<int>(rows.b.size()), n);
  a.setFromTriplets(rows.a.begin(), rows.a.end());
  Eigen::SparseMatrix<double> normal = a.transpose() * a;
  for (int g = 0; g < n; ++g) normal.coeffRef(g, g) += kRidge;
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(normal);
  if (ldlt.info() != Eigen::Success) return move;
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::VectorXd b(static_cast<int>(rows.b.size()));
    for (std::size_t r = 0; r < rows.b.size(); ++r) b(static_cast<int>(r)) = rows.b[r](axis);
    const Eigen::VectorXd d = ldlt.solve(a.transpose() * b);
    for (int g = 0; g < n; ++g) move[static_cast<std::size_t>(g)](axis) = d(g);
  }
  return move;
}

std::shared_ptr<const RubberSheet> movedSheet(const RubberSheet& through, ControlPointSelection cps,
                                              std::vector<PointPair> beside,
                                              const std::vector<Eigen::Vector3d>& move,
                                              const Cuboid& cuboid) {
  const std::vector<int> owner = ownersOf(cps, beside);
  for (std::size_t k = 0; k < cps.points.size(); ++k) cps.points[k].target += move[k];
  for (std::size_t b = 0; b < beside.size(); ++b) {
    if (owner[b] >= 0) beside[b].target += move[static_cast<std::size_t>(owner[b])];
  }
  return through.retargeted(sheetTargets(cps, beside, cuboid), through.outsideTransform());
}

}  // namespace flexcloud
