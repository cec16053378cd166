#include "flexcloud/sheet/beside_points.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "flexcloud/input/trajectory.h"
#include "position_grid.h"

namespace flexcloud {
namespace {

constexpr double kLeastBeside = 1.5;  // m: a point beside nearer its pass than this is no help
// A second ring of points beside, this many times as far out: beyond the first ring the sheet
// runs out to the cuboid's corners, which keep the rigid alignment, and a point 30-50 m out lost
// the rotation of its correction (KITTI 01 with RTK GNSS, vertical RMSE 30-50 m out 0.45 m,
// each point's own fused pose 0.18). With it, RTK GNSS, away from revisits: KITTI 0.13-0.76 m
// horizontally (0.20-0.85 without), 0.10-0.62 vertically (0.11-0.69; 04 0.57 against 0.25, its
// fused roll 1.6 degrees off now reaching the map as its own poses' map has it), MulRan 3.0-9.2
// m horizontally (3.9-15.8); simulated maps 4 % worse (open_urban_end) to 39 % better (open_rtk).
constexpr double kOuterRing = 2.0;

Eigen::Isometry3d isometry(const Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = p.orientation.toRotationMatrix();
  t.translation() = p.position;
  return t;
}

/// The body's axes (bodyAxes()) turned to the nearest of its own axes: a section's points lie
/// along the axis the body's left is nearest to and the one its up is nearest to, not at fixed
/// body y and z (a body driving along y, as KITTI's odometry does, would put them on the road
/// ahead and behind). Poses moving along +x or -x with z up keep y and z.
struct SectionAxes {
  Eigen::Vector3d left, up;
};
SectionAxes sectionAxes(const Trajectory& slam) {
  const BodyAxes a = bodyAxes(slam);
  Eigen::Index ahead = 0, up = 0;
  a.ahead.cwiseAbs().maxCoeff(&ahead);
  Eigen::Vector3d rest = a.up.cwiseAbs();
  rest(ahead) = -1.0;
  rest.maxCoeff(&up);
  const Eigen::Index left = 3 - ahead - up;
  return {Eigen::Vector3d::Unit(left), std::copysign(1.0, a.up(up)) * Eigen::Vector3d::Unit(up)};
}

}  // namespace

std::vector<PointPair> besidePoints(const ControlPointSelection& cps, const Trajectory& slam,
                                    const Trajectory& fused, double beside, double above,
                                    const std::vector<bool>& steady) {
  std::vector<PointPair> out;
  if (beside <= 0.0 && above <= 0.0) return out;
  // Cross-sections at every control point at least `spacing` of path from the previous one:
  // refined control points may lie close together, and sections closer than their size would
  // make flat tetrahedra. The lateral points alternate up and down by a quarter of the section
  // size, so that no four neighbours lie in one plane (a flat road would otherwise give flat
  // tetrahedra whose transforms amplify every small difference of the targets).
  const double size = std::max(beside, above);
  const double spacing = 0.8 * size;
  const double stagger = 0.25 * size;
  const std::vector<double> arc = arcLength(positionsOf(slam));
  const PositionGrid grid(slam, std::max(5.0, 0.5 * size));
  const SectionAxes axes = sectionAxes(slam);
  double last = -std::numeric_limits<double>::infinity();
  int section = 0;
  for (std::size_t c = 0; c < cps.points.size(); ++c) {
    const auto& cp = cps.points[c];
    if (!steady.empty() && !steady[cp.pose_index]) continue;
    // The first and last control points always get a section: the rotation at the ends of the
    // drive has nothing beyond it to be interpolated from.
    const bool end = c + 1 == cps.points.size();
    if (arc[cp.pose_index] - last < (end ? 0.3 * spacing : spacing)) continue;
    last = arc[cp.pose_index];
    const double z = (section++ % 2 == 0) ? stagger : -stagger;
    std::vector<Eigen::Vector3d> offsets;
    if (beside > 0.0) {
      const double outer = kOuterRing * beside;
      offsets = {beside * axes.left + z * axes.up, -beside * axes.left - z * axes.up,
                 outer * axes.left - z * axes.up, -outer * axes.left + z * axes.up};
    }
    if (above > 0.0) offsets.push_back(above * axes.up);
    const Eigen::Isometry3d s = isometry(slam[cp.pose_index]);
    const Eigen::Isometry3d f = isometry(fused[cp.pose_index]);
    for (const auto& full : offsets) {
      // Where another pass lies near, the point moves in towards its own pass (halving its
      // offset, down to kLeastBeside): each pass keeps its own correction up to near halfway.
      for (Eigen::Vector3d o = full; o.norm() >= kLeastBeside; o *= 0.5) {
        const Eigen::Vector3d source = s * o;
        if (grid.anyWithin(source, 0.7 * o.norm())) continue;
        out.push_back({source, f * o, cp.pose_index});
        break;
      }
    }
  }
  return out;
}

namespace {

/// Whether the tetrahedron's vertices belong to poses more than pass_gap of path apart.
bool spansPasses(const std::array<int, 4>& tet, const std::vector<double>& vertex_arc,
                 double pass_gap) {
  if (vertex_arc.empty()) return false;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int v : tet) {
    const double a = vertex_arc[static_cast<std::size_t>(v)];
    if (std::isnan(a)) continue;
    lo = std::min(lo, a), hi = std::max(hi, a);
  }
  return hi - lo > pass_gap;
}

}  // namespace

std::vector<std::size_t> foldingPoints(const RubberSheet& sheet,
                                       const std::vector<PointPair>& pairs,
                                       const Eigen::Isometry3d& input_to_source,
                                       const std::vector<double>& vertex_arc, double pass_gap) {
  constexpr double kSame = 1e-6;  // m
  CellMap<std::vector<std::size_t>> where;
  std::vector<Eigen::Vector3d> moved(pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    moved[i] = input_to_source * pairs[i].source;
    where[cellOf(moved[i], 1.0)].push_back(i);
  }
  std::set<std::size_t> bad;
  const auto& tets = sheet.tetrahedra();
  for (std::size_t t = 0; t < tets.size(); ++t) {
    const double det = sheet.affineAt({static_cast<int>(t), false}).leftCols<3>().determinant();
    if (det >= 0.2 || spansPasses(tets[t], vertex_arc, pass_gap)) continue;
    for (int v : tets[t]) {
      const Eigen::Vector3d& s = sheet.sources()[static_cast<std::size_t>(v)];
      const auto it = where.find(cellOf(s, 1.0));
      if (it == where.end()) continue;
      for (std::size_t i : it->second) {
        if ((moved[i] - s).norm() < kSame) bad.insert(i);
      }
    }
  }
  return {bad.begin(), bad.end()};
}

}  // namespace flexcloud
