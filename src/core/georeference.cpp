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

Eigen::Isometry3d alignTrajectory(const GeoreferenceResult& r, const Params& params,
                                  double& scale) {
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  for (std::size_t i = 0; i < r.poses.size(); ++i) {
    if (!isUsableGnss(r.gnss_at_pose[i], r.poses[i].stamp, params)) continue;
    src.push_back(r.poses[i].position);
    dst.push_back(r.gnss_at_pose[i]->position);
  }
  if (src.size() < 3) {
    throw Error("alignment: " + std::to_string(src.size()) +
                " poses have GNSS within the std-dev threshold of " +
                std::to_string(params.stddev_threshold) + " m, at least 3 are needed");
  }
  const std::vector<double> w = arcWeights(src);
  scale = umeyama(src, dst, w, true).scale;
  return umeyama(src, dst, w, false).rigid();
}

std::array<Eigen::Vector3d, 8> makeCuboid(const GeoreferenceResult& r, const Params& params) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (std::size_t i = 0; i < r.aligned.size(); ++i) {
    lo = lo.cwiseMin(r.aligned[i].position);
    hi = hi.cwiseMax(r.aligned[i].position);
    if (r.gnss_at_pose[i]) {
      lo = lo.cwiseMin(r.gnss_at_pose[i]->position);
      hi = hi.cwiseMax(r.gnss_at_pose[i]->position);
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

std::shared_ptr<const RubberSheet> buildSheet(const GeoreferenceResult& r) {
  // The triangulation lives in the aligned frame, where the cuboid is axis-aligned.
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
  for (const auto& cp : r.control_points.points) {
    src.push_back(r.T_enu_map * cp.source);
    dst.push_back(cp.target);
  }
  // The corners keep their rigidly aligned position, and so does everything beyond them. (Moving
  // them with a global affine fit was tried: on simulated drives it multiplied the map error,
  // since the vertical shear fitted on a near-flat drive grows toward the distant corners.)
  for (const auto& c : r.cuboid_enu) {
    src.push_back(c);
    dst.push_back(c);
  }
  Affine34 outside;
  outside << r.T_enu_map.linear(), r.T_enu_map.translation();
  return std::make_shared<RubberSheet>(src, dst, outside, r.T_enu_map);
}

/// Error-driven refinement up to `total` control points (see Params::refine_fraction).
void refineControlPoints(GeoreferenceResult& r, const Params& params, std::size_t total) {
  const double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::vector<bool> usable(r.poses.size());
  std::size_t first = r.poses.size(), last = 0;
  for (std::size_t i = 0; i < r.poses.size(); ++i) {
    usable[i] = isUsableGnss(r.gnss_at_pose[i], r.poses[i].stamp, params);
    if (r.gnss_at_pose[i]) first = std::min(first, i), last = std::max(last, i);
  }
  const std::vector<double> arc = arcLength(positionsOf(r.poses));
  // A refinement keeps 1/20 of the even spacing (at the full count) of path from its neighbours:
  // enough that a standstill gathers no control points, small enough not to cost accuracy
  // (a quarter of the spacing raised the real drive's MAX at 50 control points from 1.4 to 13 m).
  const double separation =
      0.05 * (arc[last] - arc[first]) / static_cast<double>(std::max<std::size_t>(1, total - 1));
  while (r.control_points.points.size() < total) {
    const auto sheet = buildSheet(r);
    std::vector<double> deviation(r.poses.size(), kNaN);
    int hint = 0;
    for (std::size_t i = 0; i < r.poses.size(); ++i) {
      if (!usable[i]) continue;
      const auto loc = sheet->locateFrom(r.poses[i].position, hint);
      if (!loc.outside) hint = loc.tet;
      deviation[i] = (RubberSheet::apply(sheet->affineAt(loc), r.poses[i].position) -
                      r.gnss_at_pose[i]->position)
                         .norm();
    }
    const std::size_t have = r.control_points.points.size();
    const std::size_t round = std::min(total - have, std::max<std::size_t>(1, have / 4));
    const auto picks = pickRefinements(r.control_points, deviation, arc, separation, round,
                                       kMinRefineDeviation);
    if (picks.empty()) break;
    addControlPoints(r.control_points, picks, r.poses, r.gnss_at_pose);
  }
}

/// Warps a pose; `hint` carries the tetrahedron of the previous pose (a trajectory moves
/// little from pose to pose, so the walk from there is short and no grid is needed).
/// Finds pairs of control points on different passes over the same place (within 5 m of each
/// other after the alignment, more than 50 m apart along the path) whose GNSS offset disagrees
/// with their aligned SLAM offset.
RevisitCheck checkRevisits(const GeoreferenceResult& r) {
  constexpr double kRadius = 5.0, kOtherPass = 50.0;
  RevisitCheck out;
  const auto& cps = r.control_points.points;
  const std::vector<double> arc = arcLength(positionsOf(r.poses));
  CellMap<std::vector<std::size_t>> cells;
  std::vector<Eigen::Vector3d> aligned(cps.size());
  for (std::size_t i = 0; i < cps.size(); ++i) {
    aligned[i] = r.T_enu_map * cps[i].source;
    cells[cellOf(aligned[i], kRadius)].push_back(i);
  }
  for (std::size_t i = 0; i < cps.size(); ++i) {
    const Eigen::Vector3i key = cellOf(aligned[i], kRadius);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find(key + Eigen::Vector3i(dx, dy, dz));
          if (it == cells.end()) continue;
          for (std::size_t j : it->second) {
            if (j <= i || (aligned[j] - aligned[i]).norm() > kRadius ||
                std::abs(arc[cps[j].pose_index] - arc[cps[i].pose_index]) < kOtherPass) {
              continue;
            }
            ++out.pairs;
            const double d = ((cps[j].target - cps[i].target) - (aligned[j] - aligned[i])).norm();
            if (d > 0.5 + 3.0 * (cps[i].std_dev + cps[j].std_dev)) ++out.conflicting;
            out.worst = std::max(out.worst, d);
          }
        }
      }
    }
  }
  return out;
}

Pose warpPose(const RubberSheet& sheet, const Pose& p, int& hint) {
  const auto loc = sheet.locateFrom(p.position, hint);
  if (!loc.outside) hint = loc.tet;
  const Affine34& a = sheet.affineAt(loc);
  Pose out = p;
  out.position = RubberSheet::apply(a, p.position);
  out.orientation = Eigen::Quaterniond(nearestRotation(a.leftCols<3>()) *
                                       p.orientation.toRotationMatrix())
                        .normalized();
  return out;
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
  r.gnss = input.local_gnss.empty() ? prepareGeodeticGnss(input.fixes, params)
                                    : prepareLocalGnss(input.local_gnss, params);
  r.datum = r.gnss.datum;
  r.poses = preparePoses(input.poses, r.pose_counts);
  if (r.poses.empty()) {
    throw Error("poses: none of the " + std::to_string(r.pose_counts.received) +
                " poses is usable (" + std::to_string(r.pose_counts.invalid) + " invalid)");
  }
  r.seconds.gnss = watch.lap();

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
  r.seconds.interpolation = watch.lap();

  r.T_enu_map = alignTrajectory(r, params, r.scale);
  r.aligned = r.poses;
  for (auto& p : r.aligned) {
    p.position = r.T_enu_map * p.position;
    p.orientation = Eigen::Quaterniond(r.T_enu_map.linear() * p.orientation.toRotationMatrix());
  }
  r.seconds.alignment = watch.lap();

  const auto total = static_cast<std::size_t>(params.control_points);
  const auto refined = static_cast<std::size_t>(std::lround(params.refine_fraction * total));
  Params even = params;
  even.control_points = static_cast<int>(std::max<std::size_t>(4, total - refined));
  r.control_points = selectControlPoints(r.poses, r.gnss_at_pose, even);
  r.control_points.requested = total;
  if (r.control_points.points.size() < 4) {
    throw Error("control points: " + std::to_string(r.control_points.points.size()) +
                " usable of " + std::to_string(r.control_points.requested) + " requested (" +
                std::to_string(r.poses_matched) + " poses with GNSS, std-dev threshold " +
                std::to_string(params.stddev_threshold) + " m); at least 4 are needed");
  }
  r.cuboid_enu = makeCuboid(r, params);
  refineControlPoints(r, params, total);
  r.seconds.control_points = watch.lap();

  r.sheet = buildSheet(r);
  r.seconds.triangulation = watch.lap();

  r.rubbersheet.reserve(r.poses.size());
  int hint = 0;
  for (const auto& p : r.poses) r.rubbersheet.push_back(warpPose(*r.sheet, p, hint));
  std::vector<double> dev_aligned;
  std::vector<double> dev_sheet;
  for (std::size_t i = 0; i < r.poses.size(); ++i) {
    if (!r.gnss_at_pose[i]) continue;
    dev_aligned.push_back((r.aligned[i].position - r.gnss_at_pose[i]->position).norm());
    dev_sheet.push_back((r.rubbersheet[i].position - r.gnss_at_pose[i]->position).norm());
  }
  r.metrics_aligned = errorStats(dev_aligned);
  r.metrics_rubbersheet = errorStats(dev_sheet);
  for (const auto& cp : r.control_points.points) {
    r.residual_aligned.push_back((r.aligned[cp.pose_index].position - cp.target).norm());
    r.residual_rubbersheet.push_back((r.rubbersheet[cp.pose_index].position - cp.target).norm());
  }
  r.revisits = checkRevisits(r);
  r.seconds.trajectory_warp = watch.lap();
  return r;
}

}  // namespace flexcloud
