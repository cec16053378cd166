#include "flexcloud/georeference.h"

#include <Eigen/SVD>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "cell_hash.h"
#include "flexcloud/interpolation.h"
#include "flexcloud/metrics.h"

namespace flexcloud {
namespace {

class Stopwatch {
 public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

constexpr double kMinRefineDeviation = 1e-3;  // m: a deviation below this needs no control point

std::string span(double a, double b) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << "[" << a << ", " << b << "] s";
  return s.str();
}

/// Weight of each pose by the path length it stands for, so a standstill does not dominate.
std::vector<double> arcWeights(const std::vector<Eigen::Vector3d>& pts) {
  std::vector<double> w(pts.size(), 1e-3);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (i > 0) w[i] += 0.5 * (pts[i] - pts[i - 1]).norm();
    if (i + 1 < pts.size()) w[i] += 0.5 * (pts[i + 1] - pts[i]).norm();
  }
  return w;
}

/// The poses whose GNSS may anchor the result (see isUsableGnss).
std::vector<bool> usablePoses(const Trajectory& poses,
                              const std::vector<std::optional<GnssPoint>>& gnss,
                              const Params& params) {
  std::vector<bool> usable(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    usable[i] = isUsableGnss(gnss[i], poses[i].stamp, params);
  }
  return usable;
}

/// Rigid (and, for the report, similarity) Umeyama fit of the usable poses to their GNSS.
struct Alignment {
  Eigen::Isometry3d T_enu_map = Eigen::Isometry3d::Identity();
  double scale = 1.0;
};

Alignment alignTrajectory(const Trajectory& poses,
                          const std::vector<std::optional<GnssPoint>>& gnss,
                          const std::vector<bool>& usable, const Params& params) {
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!usable[i]) continue;
    src.push_back(poses[i].position);
    dst.push_back(gnss[i]->position);
  }
  if (src.size() < 3) {
    throw Error("alignment: " + std::to_string(src.size()) +
                " poses have GNSS within the std-dev threshold of " +
                std::to_string(params.stddev_threshold) + " m, at least 3 are needed");
  }
  const std::vector<double> w = arcWeights(src);
  return {umeyama(src, dst, w, false).rigid(), umeyama(src, dst, w, true).scale};
}

Trajectory transformed(const Trajectory& poses, const Eigen::Isometry3d& t) {
  Trajectory out = poses;
  for (auto& p : out) {
    p.position = t * p.position;
    p.orientation = Eigen::Quaterniond(t.linear() * p.orientation.toRotationMatrix());
  }
  return out;
}

/// The corners of the axis-aligned box around the aligned trajectory and the GNSS, grown by the
/// margins.
std::array<Eigen::Vector3d, 8> makeCuboid(const Trajectory& aligned,
                                          const std::vector<std::optional<GnssPoint>>& gnss,
                                          const Params& params) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (std::size_t i = 0; i < aligned.size(); ++i) {
    lo = lo.cwiseMin(aligned[i].position);
    hi = hi.cwiseMax(aligned[i].position);
    if (gnss[i]) {
      lo = lo.cwiseMin(gnss[i]->position);
      hi = hi.cwiseMax(gnss[i]->position);
    }
  }
  const Eigen::Vector3d extent = hi - lo;
  const Eigen::Vector3d frac(params.margin_x, params.margin_y, params.margin_z);
  const Eigen::Vector3d margin = frac.cwiseProduct(extent).cwiseMax(params.margin_min);
  lo -= margin;
  hi += margin;
  std::array<Eigen::Vector3d, 8> corners;
  for (int c = 0; c < 8; ++c) {
    corners[c] = Eigen::Vector3d((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(),
                                 (c & 4) ? hi.z() : lo.z());
  }
  return corners;
}

std::shared_ptr<const RubberSheet> buildSheet(const ControlPointSelection& cps,
                                              const Eigen::Isometry3d& T_enu_map,
                                              const std::array<Eigen::Vector3d, 8>& cuboid) {
  // The triangulation lives in the aligned frame, where the cuboid is axis-aligned.
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  for (const auto& cp : cps.points) {
    src.push_back(T_enu_map * cp.source);
    dst.push_back(cp.target);
  }
  // The corners keep their rigidly aligned position, and so does everything beyond them. (Moving
  // them with a global affine fit was tried: on simulated drives it multiplied the map error,
  // since the vertical shear fitted on a near-flat drive grows toward the distant corners.)
  for (const auto& c : cuboid) {
    src.push_back(c);
    dst.push_back(c);
  }
  Affine34 outside;
  outside << T_enu_map.linear(), T_enu_map.translation();
  return std::make_shared<RubberSheet>(src, dst, outside, T_enu_map);
}

/// Deviation (m) of each usable pose, warped by the sheet, from its GNSS; NaN elsewhere.
std::vector<double> sheetDeviation(const RubberSheet& sheet, const Trajectory& poses,
                                   const std::vector<std::optional<GnssPoint>>& gnss,
                                   const std::vector<bool>& usable) {
  std::vector<double> deviation(poses.size(), std::numeric_limits<double>::quiet_NaN());
  int hint = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!usable[i]) continue;
    const auto loc = sheet.locateFrom(poses[i].position, hint);
    if (!loc.outside) hint = loc.tet;
    deviation[i] =
        (RubberSheet::apply(sheet.affineAt(loc), poses[i].position) - gnss[i]->position).norm();
  }
  return deviation;
}

/// Error-driven refinement of `cps` up to `total` control points (Params::refine_fraction).
void refineControlPoints(ControlPointSelection& cps, const Trajectory& poses,
                         const std::vector<std::optional<GnssPoint>>& gnss,
                         const std::vector<bool>& usable, const Eigen::Isometry3d& T_enu_map,
                         const std::array<Eigen::Vector3d, 8>& cuboid, std::size_t total) {
  std::size_t first = poses.size(), last = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (gnss[i]) first = std::min(first, i), last = std::max(last, i);
  }
  const std::vector<double> arc = arcLength(positionsOf(poses));
  // A refinement keeps 1/20 of the even spacing (at the full count) of path from its neighbours:
  // enough that a standstill gathers no control points, small enough not to cost accuracy
  // (a quarter of the spacing raised the real drive's MAX at 50 control points from 1.4 to 13 m).
  const double separation =
      0.05 * (arc[last] - arc[first]) / static_cast<double>(std::max<std::size_t>(1, total - 1));
  while (cps.points.size() < total) {
    const auto sheet = buildSheet(cps, T_enu_map, cuboid);
    const std::vector<double> deviation = sheetDeviation(*sheet, poses, gnss, usable);
    const std::size_t have = cps.points.size();
    const std::size_t round = std::min(total - have, std::max<std::size_t>(1, have / 4));
    const auto picks = pickRefinements(cps, deviation, arc, separation, round, kMinRefineDeviation);
    if (picks.empty()) break;
    addControlPoints(cps, picks, poses, gnss);
  }
}

/// Finds pairs of control points on different passes over the same place (within kRadius of
/// each other after the alignment, more than kOtherPass apart along the path) whose GNSS offset
/// disagrees with their aligned SLAM offset.
RevisitCheck checkRevisits(const ControlPointSelection& cps, const Trajectory& poses,
                           const Eigen::Isometry3d& T_enu_map) {
  constexpr double kRadius = 5.0, kOtherPass = 50.0;
  RevisitCheck out;
  const auto& pts = cps.points;
  const std::vector<double> arc = arcLength(positionsOf(poses));
  CellMap<std::vector<std::size_t>> cells;
  std::vector<Eigen::Vector3d> aligned(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    aligned[i] = T_enu_map * pts[i].source;
    cells[cellOf(aligned[i], kRadius)].push_back(i);
  }
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3i key = cellOf(aligned[i], kRadius);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find(key + Eigen::Vector3i(dx, dy, dz));
          if (it == cells.end()) continue;
          for (std::size_t j : it->second) {
            if (j <= i || (aligned[j] - aligned[i]).norm() > kRadius ||
                std::abs(arc[pts[j].pose_index] - arc[pts[i].pose_index]) < kOtherPass) {
              continue;
            }
            ++out.pairs;
            const double d = ((pts[j].target - pts[i].target) - (aligned[j] - aligned[i])).norm();
            if (d > 0.5 + 3.0 * (pts[i].std_dev + pts[j].std_dev)) ++out.conflicting;
            out.worst = std::max(out.worst, d);
          }
        }
      }
    }
  }
  return out;
}

/// Warps a pose; `hint` carries the tetrahedron of the previous pose (a trajectory moves
/// little from pose to pose, so the walk from there is short and no grid is needed).
Pose warpPose(const RubberSheet& sheet, const Pose& p, int& hint) {
  const auto loc = sheet.locateFrom(p.position, hint);
  if (!loc.outside) hint = loc.tet;
  const Affine34& a = sheet.affineAt(loc);
  Pose out = p;
  out.position = RubberSheet::apply(a, p.position);
  out.orientation =
      Eigen::Quaterniond(nearestRotation(a.leftCols<3>()) * p.orientation.toRotationMatrix())
          .normalized();
  return out;
}

Trajectory warpTrajectory(const RubberSheet& sheet, const Trajectory& poses) {
  Trajectory out;
  out.reserve(poses.size());
  int hint = 0;
  for (const auto& p : poses) out.push_back(warpPose(sheet, p, hint));
  return out;
}

/// Deviation of a trajectory from the GNSS at every matched pose.
ErrorStats deviationFromGnss(const Trajectory& t,
                             const std::vector<std::optional<GnssPoint>>& gnss) {
  std::vector<double> d;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (gnss[i]) d.push_back((t[i].position - gnss[i]->position).norm());
  }
  return errorStats(d);
}

/// The GNSS and the poses, checked and prepared; throws when nothing usable is left.
void prepareInput(const DriveInput& input, const Params& params, GeoreferenceResult& r) {
  r.gnss = input.local_gnss.empty() ? prepareGeodeticGnss(input.fixes, params)
                                    : prepareLocalGnss(input.local_gnss, params);
  r.datum = r.gnss.datum;
  r.poses = preparePoses(input.poses, r.pose_counts);
  if (r.poses.empty()) {
    throw Error("poses: none of the " + std::to_string(r.pose_counts.received) +
                " poses is usable (" + std::to_string(r.pose_counts.invalid) + " invalid)");
  }
}

/// The GNSS at every pose stamp; throws when no pose has any.
void matchGnss(const Params& params, GeoreferenceResult& r) {
  std::vector<double> stamps;
  stamps.reserve(r.poses.size());
  for (const auto& p : r.poses) stamps.push_back(p.stamp);
  r.gnss_at_pose = interpolateGnss(r.gnss.points, stamps, params);
  for (const auto& g : r.gnss_at_pose) r.poses_matched += g.has_value() ? 1 : 0;
  if (r.poses_matched == 0) {
    throw Error("no time overlap: GNSS spans " +
                span(r.gnss.points.front().stamp, r.gnss.points.back().stamp) + ", poses span " +
                span(r.poses.front().stamp, r.poses.back().stamp) +
                " (GNSS gaps longer than max_gap are not bridged)");
  }
}

/// A quarter (1 - refine_fraction) of the control points spread evenly, the rest refined.
ControlPointSelection chooseControlPoints(const GeoreferenceResult& r,
                                          const std::vector<bool>& usable, const Params& params) {
  const auto total = static_cast<std::size_t>(params.control_points);
  const auto refined = static_cast<std::size_t>(std::lround(params.refine_fraction * total));
  Params even = params;
  even.control_points = static_cast<int>(std::max<std::size_t>(4, total - refined));
  ControlPointSelection cps = selectControlPoints(r.poses, r.gnss_at_pose, even);
  cps.requested = total;
  if (cps.points.size() < 4) {
    throw Error("control points: " + std::to_string(cps.points.size()) + " usable of " +
                std::to_string(cps.requested) + " requested (" + std::to_string(r.poses_matched) +
                " poses with GNSS, std-dev threshold " + std::to_string(params.stddev_threshold) +
                " m); at least 4 are needed");
  }
  refineControlPoints(cps, r.poses, r.gnss_at_pose, usable, r.T_enu_map, r.cuboid_enu, total);
  return cps;
}

}  // namespace

std::vector<std::string> resultWarnings(const GeoreferenceResult& r, const Params& params,
                                        const WarpStats* map) {
  std::vector<std::string> out;
  auto percent = [](double share) { return std::to_string(std::lround(100.0 * share)) + " %"; };
  const double poses_without =
      r.poses.empty() ? 0.0 : 1.0 - static_cast<double>(r.poses_matched) / r.poses.size();
  if (poses_without > params.max_uncovered_share) {
    out.push_back(percent(poses_without) + " of the poses have no GNSS: they are corrected by " +
                  "the nearest control points only, or by the rigid transform");
  }
  if (map != nullptr && map->points > map->non_finite) {
    const double outside =
        static_cast<double>(map->outside) / static_cast<double>(map->points - map->non_finite);
    if (outside > params.max_uncovered_share) {
      out.push_back(percent(outside) + " of the map points lie beyond the GNSS coverage: they " +
                    "got the rigid transform only, without drift correction");
    }
  }
  if (r.revisits.conflicting > 0) {
    std::ostringstream s;
    s.precision(3);
    s << r.revisits.conflicting << " control point pairs revisit places that the SLAM map puts "
      << "elsewhere on another pass (up to " << r.revisits.worst
      << " m): close those loops in the SLAM, no warp can merge ghosted passes";
    out.push_back(s.str());
  }
  return out;
}

Trajectory gnssTrajectory(const GeoreferenceResult& r) {
  Trajectory t;
  t.reserve(r.poses_matched);
  for (std::size_t i = 0; i < r.poses.size(); ++i) {
    if (!r.gnss_at_pose[i]) continue;
    Pose p;
    p.stamp = r.poses[i].stamp;
    p.position = r.gnss_at_pose[i]->position;
    t.push_back(p);
  }
  return t;
}

Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  if ((u * svd.matrixV().transpose()).determinant() < 0.0) u.col(2) *= -1.0;
  return u * svd.matrixV().transpose();
}

GeoreferenceResult georeference(const DriveInput& input, const Params& params) {
  if (const std::string bad = params.validate(); !bad.empty()) throw Error("parameters: " + bad);
  if (!input.fixes.empty() && !input.local_gnss.empty()) {
    throw Error("input: give geodetic fixes or local GNSS points, not both");
  }
  GeoreferenceResult r;
  Stopwatch watch;
  prepareInput(input, params, r);
  r.seconds.gnss = watch.lap();
  matchGnss(params, r);
  r.seconds.interpolation = watch.lap();

  const std::vector<bool> usable = usablePoses(r.poses, r.gnss_at_pose, params);
  const Alignment a = alignTrajectory(r.poses, r.gnss_at_pose, usable, params);
  r.T_enu_map = a.T_enu_map;
  r.scale = a.scale;
  r.aligned = transformed(r.poses, r.T_enu_map);
  r.seconds.alignment = watch.lap();

  r.cuboid_enu = makeCuboid(r.aligned, r.gnss_at_pose, params);
  r.control_points = chooseControlPoints(r, usable, params);
  r.seconds.control_points = watch.lap();
  r.sheet = buildSheet(r.control_points, r.T_enu_map, r.cuboid_enu);
  r.seconds.triangulation = watch.lap();

  r.rubbersheet = warpTrajectory(*r.sheet, r.poses);
  r.metrics_aligned = deviationFromGnss(r.aligned, r.gnss_at_pose);
  r.metrics_rubbersheet = deviationFromGnss(r.rubbersheet, r.gnss_at_pose);
  for (const auto& cp : r.control_points.points) {
    r.residual_aligned.push_back((r.aligned[cp.pose_index].position - cp.target).norm());
    r.residual_rubbersheet.push_back((r.rubbersheet[cp.pose_index].position - cp.target).norm());
  }
  r.revisits = checkRevisits(r.control_points, r.poses, r.T_enu_map);
  r.seconds.trajectory_warp = watch.lap();
  return r;
}

}  // namespace flexcloud
