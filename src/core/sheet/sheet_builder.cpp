#include "sheet/sheet_builder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/metrics.h"
#include "sheet/sheet_fit.h"

namespace flexcloud {
namespace {

constexpr double kMinRefineDeviation = 1e-3;  // m: a deviation below this needs no control point
// Vertices of poses more than this many section sizes of path apart belong to different passes.
constexpr double kPassGapSizes = 8.0;
// m: a pose the sheet carries further than this from its fused pose gets a control point of
// its own, for at most this many rounds.
constexpr double kFaithful = 0.05;
constexpr int kFaithfulRounds = 4;
// m: rounds go on past kFaithfulRounds, up to kFoldRounds, while the best sheet so far carries a
// pose further than this from its fused pose. With the outer ring of points beside, a few poses
// lay 0.40-0.53 m off after four rounds (MulRan DCC_02, Riverside_03 with RTK GNSS: trajectory
// MAX 0.53 and 0.40 m, 0.20 and 0.28 without the ring); going on, 0.22 and 0.30 m. a2rl, whose
// sheet folds in its tight curves, takes more rounds: control points 0.51 s against 0.16 s.
constexpr double kUnfaithful = 0.3;
constexpr int kFoldRounds = 10;
// m: a sheet that carries a pose this far from its fused pose has folded (passes of a drive
// that the SLAM puts metres apart, the points beside one lying near the other): KITTI 02 with
// RTK GNSS folds 5-9 m for the first 2-5 rounds at 100-200 control points.
constexpr double kFold = 1.0;
constexpr double kFaithfulSeparation = 0.05;
// A break lies beyond this many times the typical deviation. The fused trajectory follows
// precise fixes pose by pose, where a real SLAM jumps or bends within a few metres: at 10
// times the sheet stayed up to 0.55 m off it on KITTI 02 with RTK GNSS (0.26 m at 3 times),
// and a2rl's held-out fixes (every 10th, outside poses 306-358) were 0.144 / 0.771 m off in MAE
// / MAX (in 3 rounds 0.115 / 0.532 m, 431 control points where 200 were asked for, 0.17 s; in 4
// rounds 0.103 / 0.433 m, 530, 0.23 s; in 6, 0.092 / 0.531 m, 863, 0.40 s). Looking for the
// breaks on the sheet without its points beside was 4 times faster and let it fold: KITTI 02
// 6.99 m off.
constexpr double kBreakMedians = 3.0;

/// Path (m) beyond which the vertices of two poses belong to different passes.
double passGap(const SheetOptions& options) {
  return kPassGapSizes * std::max(options.beside_distance, options.above_height);
}

/// Per vertex of the sheet, the path (m) of the pose it belongs to: the control points', then
/// the points beside them, NaN for the cuboid's corners; empty where the sheet merged vertices
/// (the order then no longer tells which is which).
std::vector<double> vertexArcs(const RubberSheet& sheet, const ControlPointSelection& cps,
                               const std::vector<PointPair>& beside,
                               const std::vector<double>& arc) {
  if (sheet.merged() != 0 || sheet.sources().size() != cps.points.size() + beside.size() + 8) {
    return {};
  }
  std::vector<double> out;
  for (const auto& cp : cps.points) out.push_back(arc[cp.pose_index]);
  for (const auto& b : beside) out.push_back(arc[b.pose_index]);
  out.resize(sheet.sources().size(), std::numeric_limits<double>::quiet_NaN());
  return out;
}

/// The usable poses and, for each, the sheet's image of it less its target.
struct Deviations {
  std::vector<std::size_t> pose;
  std::vector<Eigen::Vector3d> offset;
};

Deviations sheetOffsets(const RubberSheet& sheet, const Trajectory& poses,
                        const std::vector<std::optional<GnssPoint>>& targets,
                        const std::vector<bool>& usable) {
  Deviations d;
  int hint = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!usable[i]) continue;
    const auto loc = sheet.locateFrom(poses[i].position, hint);
    if (!loc.outside) hint = loc.tet;
    d.pose.push_back(i);
    d.offset.push_back(RubberSheet::apply(sheet.affineAt(loc), poses[i].position) -
                       targets[i]->position);
  }
  return d;
}

/// score(k) for each of d's poses, at the pose's index among `poses` poses; NaN elsewhere.
template <typename Score>
std::vector<double> perPose(const Deviations& d, std::size_t poses, const Score& score) {
  std::vector<double> out(poses, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < d.pose.size(); ++k) out[d.pose[k]] = score(k);
  return out;
}

/// Deviation (m) of each usable pose, warped by the sheet, from its target; NaN elsewhere.
std::vector<double> sheetDeviation(const RubberSheet& sheet, const Trajectory& poses,
                                   const std::vector<std::optional<GnssPoint>>& targets,
                                   const std::vector<bool>& usable) {
  const Deviations d = sheetOffsets(sheet, poses, targets, usable);
  return perPose(d, poses.size(), [&](std::size_t k) { return d.offset[k].norm(); });
}

/// Deviation (m) of each usable pose from its fix as far as its neighbours agree: the
/// component-wise median of its own offset and the two usable neighbours', less how far its own
/// offset lies from that median (never below 0); NaN elsewhere. A lone pose off its neighbours
/// scores low, and a control point there would carry its offset to everything around it: a
/// GNSS spike, a SLAM pose that jumped, or GNSS interpolated at the pose from stamps that do not
/// match the motion. A stretch where the sheet and the fixes part, a step or a bend in the
/// offsets score in full. `fusion: false`, every 4th fix held out (MAE / MAX of the held-out
/// fixes): on monza, whose stamps are made up, the GNSS interpolated at a held-out pose lies up
/// to 0.6 m from the car, and the raw deviation put 106 of 200 control points on such poses
/// (0.220 / 0.800 m); this 33 (0.051 / 0.473 m). a2rl 0.123 / 0.482 -> 0.106 / 0.791 m. Five
/// neighbours instead of three: the same on monza, a2rl's MAX 1.33 m.
std::vector<double> consensusDeviation(const RubberSheet& sheet, const Trajectory& poses,
                                       const std::vector<std::optional<GnssPoint>>& fixes,
                                       const std::vector<bool>& usable) {
  const Deviations d = sheetOffsets(sheet, poses, fixes, usable);
  const std::size_t n = d.pose.size();
  return perPose(d, poses.size(), [&](std::size_t k) {
    const std::size_t lo = k == 0 ? 0 : k - 1;
    const std::size_t hi = std::min(n - 1, k + 1);
    Eigen::Vector3d middle;
    for (int axis = 0; axis < 3; ++axis) {
      // The median of two or three (of two the upper, as median() takes it), without a copy.
      std::array<double, 3> v{};
      std::size_t m = 0;
      for (std::size_t j = lo; j <= hi; ++j) v[m++] = d.offset[j](axis);
      std::sort(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m));
      middle(axis) = v[m / 2];
    }
    return std::max(0.0, middle.norm() - (d.offset[k] - middle).norm());
  });
}

/// Error-driven refinement of `cps` up to `total` control points (Params::refine_fraction).
void refineControlPoints(ControlPointSelection& cps, const Trajectory& poses,
                         const std::vector<std::optional<GnssPoint>>& gnss,
                         const std::vector<bool>& usable, const Eigen::Isometry3d& T_enu_map,
                         const Cuboid& cuboid, std::size_t total, bool fixes) {
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
    const auto sheet = buildSheet(cps, {}, T_enu_map, cuboid);
    const std::vector<double> deviation = fixes ? consensusDeviation(*sheet, poses, gnss, usable)
                                                : sheetDeviation(*sheet, poses, gnss, usable);
    const std::size_t have = cps.points.size();
    const std::size_t round = std::min(total - have, std::max<std::size_t>(1, have / 4));
    const auto picks = pickRefinements(cps, deviation, arc, separation, round, kMinRefineDeviation);
    if (picks.empty()) break;
    addControlPoints(cps, picks, poses, gnss);
  }
}

/// The poses that may carry points beside (steady ones, or all where `steady` is empty): the
/// control points chosen first, and every pose beyond their span (the ends of a drive whose
/// fixes start late or stop early, where added control points alone reach). A section at a
/// control point added in a round moves every later section along the drive (each keeps a
/// section's size of path from the one before), and with it the tetrahedra of every pass near
/// them: on MulRan's city drives, whose passes the SLAM puts up to 38 m apart, the sheet was
/// still 7-11 m off the fused trajectory after ten rounds (KAIST_03); with these alone, within
/// 0.5 m after six. Where the sheet does not fold, the sections of every round serve better
/// (a2rl's held-out fixes: 0.433 against 0.529 m MAX).
std::vector<bool> firstSections(const ControlPointSelection& cps, const std::vector<bool>& steady,
                                std::size_t poses) {
  std::vector<bool> out(poses, false);
  if (cps.points.empty()) return out;
  const auto may = [&](std::size_t i) { return steady.empty() || steady[i]; };
  std::size_t lo = poses, hi = 0;
  for (const auto& cp : cps.points) {
    out[cp.pose_index] = may(cp.pose_index);
    lo = std::min(lo, cp.pose_index), hi = std::max(hi, cp.pose_index);
  }
  for (std::size_t i = 0; i < poses; ++i) {
    if (i < lo || i > hi) out[i] = may(i);
  }
  return out;
}

}  // namespace

Cuboid makeCuboid(const Trajectory& aligned, const std::vector<std::optional<GnssPoint>>& gnss,
                  const SheetOptions& options) {
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
  const Eigen::Vector3d margin = options.margin.cwiseProduct(extent).cwiseMax(options.margin_min);
  lo -= margin;
  hi += margin;
  std::array<Eigen::Vector3d, 8> corners;
  for (int c = 0; c < 8; ++c) {
    corners[c] = Eigen::Vector3d((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(),
                                 (c & 4) ? hi.z() : lo.z());
  }
  return corners;
}

std::vector<Eigen::Vector3d> sheetTargets(const ControlPointSelection& cps,
                                          const std::vector<PointPair>& extra,
                                          const Cuboid& cuboid) {
  std::vector<Eigen::Vector3d> dst;
  for (const auto& cp : cps.points) dst.push_back(cp.target);
  for (const auto& e : extra) dst.push_back(e.target);
  // The corners keep their rigidly aligned position, and so does everything beyond them. (Moving
  // them with a global affine fit was tried: on simulated drives it multiplied the map error,
  // since the vertical shear fitted on a near-flat drive grows toward the distant corners.)
  dst.insert(dst.end(), cuboid.begin(), cuboid.end());
  return dst;
}

std::shared_ptr<const RubberSheet> buildSheet(const ControlPointSelection& cps,
                                              const std::vector<PointPair>& extra,
                                              const Eigen::Isometry3d& T_enu_map,
                                              const Cuboid& cuboid) {
  // The triangulation lives in the aligned frame, where the cuboid is axis-aligned.
  std::vector<Eigen::Vector3d> src;
  for (const auto& cp : cps.points) src.push_back(T_enu_map * cp.source);
  for (const auto& e : extra) src.push_back(T_enu_map * e.source);
  src.insert(src.end(), cuboid.begin(), cuboid.end());
  const std::vector<Eigen::Vector3d> dst = sheetTargets(cps, extra, cuboid);
  Affine34 outside;
  outside << T_enu_map.linear(), T_enu_map.translation();
  return std::make_shared<RubberSheet>(src, dst, outside, T_enu_map);
}

ControlPointSelection chooseControlPoints(const Trajectory& poses,
                                          const std::vector<std::optional<GnssPoint>>& targets,
                                          const std::vector<bool>& usable,
                                          const Eigen::Isometry3d& T_enu_map, const Cuboid& cuboid,
                                          const SheetOptions& options) {
  const auto total = static_cast<std::size_t>(options.control_points.count);
  const auto refined = static_cast<std::size_t>(std::lround(options.refine_fraction * total));
  ControlPointOptions even = options.control_points;
  even.count = static_cast<int>(std::max<std::size_t>(4, total - refined));
  ControlPointSelection cps = selectControlPoints(poses, targets, even);
  cps.requested = total;
  if (cps.points.size() < 4) {
    std::size_t with_target = 0;
    for (const auto& t : targets) with_target += t.has_value() ? 1 : 0;
    throw Error("control points: " + std::to_string(cps.points.size()) + " usable of " +
                std::to_string(cps.requested) + " requested (" + std::to_string(with_target) +
                " poses with GNSS, std-dev threshold " +
                std::to_string(options.control_points.stddev_threshold) +
                " m); at least 4 are needed");
  }
  refineControlPoints(cps, poses, targets, usable, T_enu_map, cuboid, total,
                      options.targets_are_fixes);
  return cps;
}

SheetWithBeside buildSheetWithBeside(const ControlPointSelection& cps, const Trajectory& slam,
                                     const Trajectory& fused, const Eigen::Isometry3d& T_enu_map,
                                     const Cuboid& cuboid, const SheetOptions& options,
                                     const std::vector<bool>& steady) {
  SheetWithBeside out;
  out.beside =
      besidePoints(cps, slam, fused, options.beside_distance, options.above_height, steady);
  const std::vector<double> arc = arcLength(positionsOf(slam));
  const double pass_gap = passGap(options);
  for (int round = 0;; ++round) {
    const auto through = buildSheet(cps, out.beside, T_enu_map, cuboid);
    const auto move = fitSheetTargets(*through, cps, out.beside, slam, fused);
    out.sheet = movedSheet(*through, cps, out.beside, move, cuboid);
    const std::vector<std::size_t> bad = foldingPoints(
        *out.sheet, out.beside, T_enu_map, vertexArcs(*out.sheet, cps, out.beside, arc), pass_gap);
    if (bad.empty() || round == 3) break;
    std::vector<PointPair> kept;
    std::size_t b = 0;
    for (std::size_t i = 0; i < out.beside.size(); ++i) {
      if (b < bad.size() && bad[b] == i) {
        ++b;
        continue;
      }
      kept.push_back(out.beside[i]);
    }
    out.folding += bad.size();
    out.beside.swap(kept);
  }
  return out;
}

namespace {

/// A faithful sheet and how far it carries a pose off its fused pose at worst (m).
struct Faithful {
  SheetWithBeside sheet;
  double worst = std::numeric_limits<double>::infinity();
};

/// The rounds of buildFaithfulSheet(), with points beside the poses `beside_at` allows.
Faithful faithfulRounds(ControlPointSelection& cps, const Trajectory& slam, const Trajectory& fused,
                        const std::vector<std::optional<GnssPoint>>& targets,
                        const std::vector<bool>& usable, const Eigen::Isometry3d& T_enu_map,
                        const Cuboid& cuboid, const SheetOptions& options,
                        const std::vector<bool>& beside_at) {
  const std::vector<double> arc = arcLength(positionsOf(slam));
  // Added control points keep 5 cm of path from their neighbours: where the car stops, the
  // last poses lie a few centimetres apart.
  const double separation = kFaithfulSeparation;
  std::size_t added = 0;
  // The last sheet that carries no pose further off than the best before it, give or take a
  // break's threshold, and its control points: a round's control points change the points
  // beside them, and the last round's sheet is not checked by a round after it (KITTI 02 with
  // RTK GNSS at 100 and 150 control points: its last sheet 1.24 and 0.89 m off the fused
  // trajectory, where the round before it stayed within 0.40 and 0.28 m).
  std::optional<Faithful> best;
  ControlPointSelection best_cps;
  for (int round = 0;; ++round) {
    SheetWithBeside out =
        buildSheetWithBeside(cps, slam, fused, T_enu_map, cuboid, options, beside_at);
    out.added = added;
    const std::vector<double> deviation = sheetDeviation(*out.sheet, slam, targets, usable);
    // A break, not the sheet's resolution (which the number of control points asked for sets):
    // beyond kFaithful and beyond kBreakMedians times the typical deviation.
    std::vector<double> finite;
    for (double d : deviation) {
      if (std::isfinite(d)) finite.push_back(d);
    }
    if (finite.empty()) return {std::move(out), 0.0};
    const double worst = *std::max_element(finite.begin(), finite.end());
    const double least = std::max(kFaithful, kBreakMedians * median(finite));
    if (!best || worst <= best->worst + least)
      best = Faithful{std::move(out), worst}, best_cps = cps;
    const bool last =
        round >= kFoldRounds || (round >= kFaithfulRounds && best->worst <= kUnfaithful);
    const auto picks =
        last ? std::vector<std::size_t>{}
             : pickRefinements(cps, deviation, arc, separation, cps.points.size(), least);
    if (picks.empty()) break;
    addControlPoints(cps, picks, slam, targets);
    added += picks.size();
  }
  cps = std::move(best_cps);
  return std::move(*best);
}

}  // namespace

SheetWithBeside buildFaithfulSheet(ControlPointSelection& cps, const Trajectory& slam,
                                   const Trajectory& fused,
                                   const std::vector<std::optional<GnssPoint>>& targets,
                                   const std::vector<bool>& usable,
                                   const Eigen::Isometry3d& T_enu_map, const Cuboid& cuboid,
                                   const SheetOptions& options, const std::vector<bool>& steady) {
  const ControlPointSelection first = cps;
  Faithful all = faithfulRounds(cps, slam, fused, targets, usable, T_enu_map, cuboid, options,
                                steady.empty() ? std::vector<bool>(slam.size(), true) : steady);
  if (!(all.worst > kFold)) return std::move(all.sheet);
  // Still folded: again from the first control points, with points beside those alone.
  ControlPointSelection again = first;
  Faithful few = faithfulRounds(again, slam, fused, targets, usable, T_enu_map, cuboid, options,
                                firstSections(first, steady, slam.size()));
  if (!(few.worst < all.worst)) return std::move(all.sheet);
  cps = std::move(again);
  return std::move(few.sheet);
}

}  // namespace flexcloud
