#include "flexcloud/georeference.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <regex>
#include <sstream>

#include "flexcloud/input/interpolation.h"
#include "flexcloud/input/swap_check.h"
#include "flexcloud/metrics.h"
#include "position_grid.h"
#include "sheet/revisits.h"
#include "sheet/sheet_builder.h"

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

std::string span(double a, double b) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << "[" << a << ", " << b << "] s";
  return s.str();
}

/// x rounded up to two significant digits.
double roundUp2(double x) {
  if (!(x > 0.0)) return x;
  const double unit = std::pow(10.0, std::floor(std::log10(x)) - 1.0);
  return std::ceil(x / unit - 1e-9) * unit;
}

/// " have a horizontal std-dev ... within stddev_threshold T m (their horizontal std-devs: 5th
/// percentile ..., median ..., 95th percentile ... m; stddev_threshold X keeps 95 % of them)":
/// the end of an error for a threshold that leaves too few fixes.
std::string thresholdShortfall(const std::vector<GnssPoint>& gnss, double threshold) {
  std::vector<double> h;
  for (const auto& g : gnss) {
    if (std::isfinite(g.stdDevH())) h.push_back(g.stdDevH());
  }
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << " have a horizontal std-dev (the larger of east and north) within stddev_threshold "
    << threshold << " m";
  if (h.empty()) return s.str();
  std::sort(h.begin(), h.end());
  const auto at = [&](double q) { return h[static_cast<std::size_t>(q * (h.size() - 1) + 0.5)]; };
  s << " (their horizontal std-devs: 5th percentile " << at(0.05) << " m, median " << at(0.5)
    << " m, 95th percentile " << at(0.95) << " m; stddev_threshold ";
  const double p95 = at(0.95);
  if (p95 > 0.0) s.precision(std::clamp(1 - static_cast<int>(std::floor(std::log10(p95))), 0, 17));
  s << roundUp2(p95) << " keeps 95 % of them)";
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
  const ControlPointOptions options = controlPointOptions(params);
  std::vector<bool> usable(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    usable[i] = isUsableGnss(gnss[i], poses[i].stamp, options);
  }
  return usable;
}

/// Rigid (and, for the report, similarity) Umeyama fit of the usable poses to their GNSS.
struct Alignment {
  Eigen::Isometry3d T_enu_map = Eigen::Isometry3d::Identity();
  double scale = 1.0;
};

/// The positions of the poses `keep` accepts (src) and of their GNSS (dst); Error when fewer
/// than 3 remain.
struct PositionPairs {
  std::vector<Eigen::Vector3d> src;
  std::vector<Eigen::Vector3d> dst;
};

PositionPairs alignmentPairs(const Trajectory& poses,
                             const std::vector<std::optional<GnssPoint>>& gnss,
                             const Params& params, const std::function<bool(std::size_t)>& keep) {
  PositionPairs out;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!keep(i)) continue;
    out.src.push_back(poses[i].position);
    out.dst.push_back(gnss[i]->position);
  }
  if (out.src.size() < 3) {
    std::vector<GnssPoint> at_poses;
    for (const auto& g : gnss) {
      if (g) at_poses.push_back(*g);
    }
    throw Error("alignment: " + std::to_string(out.src.size()) + " of " +
                std::to_string(at_poses.size()) + " poses with GNSS" +
                thresholdShortfall(at_poses, params.stddev_threshold) + ", at least 3 are needed");
  }
  return out;
}

Alignment alignTrajectory(const Trajectory& poses,
                          const std::vector<std::optional<GnssPoint>>& gnss,
                          const std::vector<bool>& usable, const Params& params) {
  const auto [src, dst] =
      alignmentPairs(poses, gnss, params, [&](std::size_t i) { return usable[i]; });
  const std::vector<double> w = arcWeights(src);
  return {umeyama(src, dst, w, false).rigid(), umeyama(src, dst, w, true).scale};
}

/// The start of the fusion: a rigid fit of the poses to every GNSS the fusion may use (std-dev
/// within the threshold or not given), reweighted twice (Cauchy) so outliers pull less.
Alignment robustAlignment(const Trajectory& poses,
                          const std::vector<std::optional<GnssPoint>>& gnss, const Params& params) {
  const auto [src, dst] = alignmentPairs(poses, gnss, params, [&](std::size_t i) {
    return gnss[i] && !(gnss[i]->stdDevH() > params.stddev_threshold);  // NaN passes
  });
  std::vector<double> w;
  const Similarity fit = robustRigidFit(src, dst, arcWeights(src), &w);
  return {fit.rigid(), umeyama(src, dst, w, true).scale};
}

/// The rigid fit of the SLAM poses to the fused ones: the rigid part of the result.
Alignment alignToFused(const Trajectory& poses, const Trajectory& fused) {
  const std::vector<Eigen::Vector3d> src = positionsOf(poses);
  const std::vector<Eigen::Vector3d> dst = positionsOf(fused);
  const std::vector<double> w = arcWeights(src);
  return {umeyama(src, dst, w, false).rigid(), umeyama(src, dst, w, true).scale};
}

/// The fused position at every pose inside the time span of the fixes the fusion used, widened
/// by `margin` seconds (the control points' targets); nothing elsewhere.
std::vector<std::optional<GnssPoint>> fusedTargets(const FusionResult& f, double margin = 0.0) {
  double first = std::numeric_limits<double>::infinity(), last = -first;
  for (const auto& o : f.fixes) {
    if (o.verdict != FixVerdict::kUsed) continue;
    first = std::min(first, o.stamp), last = std::max(last, o.stamp);
  }
  std::vector<std::optional<GnssPoint>> out(f.poses.size());
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    if (f.poses[i].stamp < first - margin || f.poses[i].stamp > last + margin) continue;
    GnssPoint g;
    g.stamp = f.poses[i].stamp;
    g.position = f.poses[i].position;
    out[i] = g;
  }
  return out;
}

Trajectory transformed(const Trajectory& poses, const Eigen::Isometry3d& t) {
  Trajectory out = poses;
  for (auto& p : out) {
    p.position = t * p.position;
    p.orientation = Eigen::Quaterniond(t.linear() * p.orientation.toRotationMatrix());
  }
  return out;
}

}  // namespace

Eigen::Matrix3d sheetRotationAt(const RubberSheet& sheet, const Eigen::Vector3d& at, int hint) {
  // Six points kProbe either side along the map's axes, warped, and the rotation that carries
  // them best (Umeyama): the rotation of the correction over the tetrahedra around the pose.
  // The pose's own tetrahedron alone is often a sliver between control points in a line, whose
  // linear part turned KITTI 05's poses by up to 160 degrees (p95 32). The walk from the pose's
  // tetrahedron leaves the sheet's grid unbuilt: a trajectory's warp on the solver's thread
  // built it with every core, whatever `threads` asked for.
  constexpr double kProbe = 5.0;  // m
  std::vector<Eigen::Vector3d> src, dst;
  for (int axis = 0; axis < 3; ++axis) {
    for (const double sign : {-1.0, 1.0}) {
      const Eigen::Vector3d q = at + sign * kProbe * Eigen::Vector3d::Unit(axis);
      src.push_back(q);
      dst.push_back(RubberSheet::apply(sheet.affineAt(sheet.locateFrom(q, hint)), q));
    }
  }
  return umeyama(src, dst, std::vector<double>(src.size(), 1.0), false).rigid().linear();
}

namespace {

/// A position through the sheet, located by a walk from `hint`, which then holds its
/// tetrahedron (unchanged beyond the hull).
Eigen::Vector3d warpPosition(const RubberSheet& sheet, const Eigen::Vector3d& at, int& hint) {
  const auto loc = sheet.locateFrom(at, hint);
  if (!loc.outside) hint = loc.tet;
  return RubberSheet::apply(sheet.affineAt(loc), at);
}

}  // namespace

Pose warpPose(const RubberSheet& sheet, const Pose& p, int& hint) {
  Pose out = p;
  out.position = warpPosition(sheet, p.position, hint);
  out.orientation = Eigen::Quaterniond(sheetRotationAt(sheet, p.position, hint) *
                                       p.orientation.toRotationMatrix())
                        .normalized();
  return out;
}

namespace {

// The fewest poses a drive can be georeferenced from: the sheet's 4 control points, one per pose.
constexpr std::size_t kLeastPoses = 4;

/// The poses through the sheet. Their orientations are `oriented`'s where given (the fused
/// trajectory, which the sheet was fitted to: the sheet's rotation around a pose is that of
/// tetrahedra between control points in a line, KITTI 05 RTK 6.6 degrees off the truth at p95
/// by sheetRotationAt, 0.62 fused), else turned by the sheet's rotation around each pose.
Trajectory warpTrajectory(const RubberSheet& sheet, const Trajectory& poses,
                          const Trajectory* oriented) {
  Trajectory out;
  out.reserve(poses.size());
  int hint = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (oriented == nullptr) {
      out.push_back(warpPose(sheet, poses[i], hint));
      continue;
    }
    Pose p = poses[i];
    p.position = warpPosition(sheet, p.position, hint);
    p.orientation = (*oriented)[i].orientation;
    out.push_back(p);
  }
  return out;
}

/// Deviation of a trajectory's antenna (the lever arm in the body frame) from the GNSS at every
/// matched pose.
ErrorStats deviationFromGnss(const Trajectory& t, const std::vector<std::optional<GnssPoint>>& gnss,
                             const Eigen::Vector3d& lever_arm) {
  std::vector<double> d;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (!gnss[i]) continue;
    const Eigen::Vector3d antenna = t[i].position + t[i].orientation * lever_arm;
    d.push_back((antenna - gnss[i]->position).norm());
  }
  return errorStats(d);
}

/// The GNSS and the poses, checked and prepared; throws when nothing usable is left.
void prepareInput(const DriveInput& input, const Params& params, GeoreferenceResult& r) {
  r.gnss = input.local_gnss.empty() ? prepareGeodeticGnss(input.fixes, gnssOptions(params))
                                    : prepareLocalGnss(input.local_gnss, gnssOptions(params));
  r.datum = r.gnss.datum;
  r.poses = preparePoses(input.poses, r.pose_counts);
  if (r.pose_counts.received == 0) throw Error("poses: none given (an empty file, topic or bag)");
  if (r.poses.size() < kLeastPoses) {
    const std::string dropped = droppedInWords(r.pose_counts);
    throw Error("poses: " + std::to_string(r.poses.size()) + " of the " +
                std::to_string(r.pose_counts.received) + " poses usable" +
                (dropped.empty() ? "" : " (" + dropped + ")") + ", at least " +
                std::to_string(kLeastPoses) + " are needed");
  }
}

/// The GNSS at every pose stamp, its stamps moved by `offset` seconds onto the SLAM's clock.
void matchGnssAt(double offset, const Params& params, GeoreferenceResult& r) {
  std::vector<double> stamps;
  stamps.reserve(r.poses.size());
  for (const auto& p : r.poses) stamps.push_back(p.stamp - offset);
  r.gnss_at_pose = interpolateGnss(r.gnss.points, stamps, interpolationOptions(params));
  r.poses_matched = 0;
  for (std::size_t i = 0; i < r.poses.size(); ++i) {
    if (!r.gnss_at_pose[i]) continue;
    r.gnss_at_pose[i]->stamp += offset;
    ++r.poses_matched;
  }
}

/// What would make two spans that do not overlap overlap: a stamp unit where one lasts about
/// 1000^k times the other, else the offset that starts the GNSS with the poses.
std::string overlapHint(double g0, double g1, double p0, double p1, double given_offset) {
  const double ratio = (p1 - p0) / std::max(g1 - g0, 1e-12);
  const char* const units[] = {"ms", "us", "ns"};
  for (int k = 0; k < 3; ++k) {
    const double f = std::pow(1000.0, k + 1);
    if (ratio > f / 3 && ratio < f * 3) {
      return std::string("; the poses last ") + std::to_string(static_cast<long long>(ratio)) +
             "x as long as the GNSS: are the poses' stamps in " + units[k] +
             "? (the tool's --poses-stamp-unit)";
    }
    if (ratio < 3 / f && ratio > 1 / (3 * f)) {
      return std::string("; the GNSS lasts ") + std::to_string(static_cast<long long>(1 / ratio)) +
             "x as long as the poses: are the GNSS stamps in " + units[k] +
             "? (the tool's --gnss-stamp-unit)";
    }
  }
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << "; if the two clocks differ by a constant, gnss_time_offset " << given_offset + (p0 - g0)
    << " (SLAM clock minus GNSS clock, s) starts the GNSS with the poses";
  return s.str();
}

/// The median interval between consecutive stamps (s; 0 with fewer than two).
template <typename T>
double medianInterval(const std::vector<T>& stamped) {
  std::vector<double> d;
  for (std::size_t i = 1; i < stamped.size(); ++i)
    d.push_back(stamped[i].stamp - stamped[i - 1].stamp);
  return d.empty() ? 0.0 : median(std::move(d));
}

/// The GNSS at every pose stamp; throws when no pose has any, or when fewer than a quarter do
/// and the poses come 300 or more times as often or as seldom as the fixes (stamps in another
/// unit: poses in microseconds counted from 0 overlap the GNSS's seconds at their start).
void matchGnss(const Params& params, GeoreferenceResult& r) {
  matchGnssAt(0.0, params, r);
  const double g0 = r.gnss.points.front().stamp, g1 = r.gnss.points.back().stamp;
  const double p0 = r.poses.front().stamp, p1 = r.poses.back().stamp;
  const double rate = medianInterval(r.poses) / medianInterval(r.gnss.points);
  if (4 * r.poses_matched < r.poses.size() && (rate > 300.0 || rate < 1.0 / 300.0)) {
    const std::string unit = overlapHint(g0, g1, p0, p1, params.gnss_time_offset);
    if (unit.find("stamps in") != std::string::npos) {
      throw Error("only " + std::to_string(r.poses_matched) + " of " +
                  std::to_string(r.poses.size()) + " poses lie within the GNSS's time span: GNSS " +
                  span(g0, g1) + ", poses " + span(p0, p1) + unit);
    }
  }
  if (r.poses_matched == 0) {
    const bool apart = g1 < p0 || p1 < g0;
    throw Error("no time overlap: GNSS spans " + span(g0, g1) + ", poses span " + span(p0, p1) +
                (apart ? overlapHint(g0, g1, p0, p1, params.gnss_time_offset)
                       : " (GNSS gaps longer than max_gap are not bridged)"));
  }
}

}  // namespace

namespace {

/// A stretch of consecutive fixes the fusion rejected.
struct RejectedStretch {
  double begin = 0.0, end = 0.0, worst = 0.0;
  std::size_t fixes = 0;
  std::size_t rough = 0;   ///< of its fixes, those rougher than their std-devs claim
  std::size_t height = 0;  ///< of its fixes, those apart in height alone (apartInHeightAlone())
};

/// Fixes apart from the fused trajectory in height alone worth a word: fewer may be the fixes'
/// own noise.
constexpr std::size_t kHeightFixes = 3;

/// The fixes that took part in the fusion or were rejected by it, by stamp.
std::vector<const FixOutcome*> judgedFixes(const FusionResult& f) {
  std::vector<const FixOutcome*> fixes;
  for (std::size_t j : judgedByStamp(f)) fixes.push_back(&f.fixes[j]);
  return fixes;
}

/// Stretches of at least kStretchSeconds and kStretchFixes consecutive fixes (of those that
/// took part) that the fusion rejected, the longest first: with `given`, those whose std-dev
/// came with them and claimed under kRtkStd (multipath or a false RTK fix); without, those
/// that came without one (their std-dev estimated, nothing claimed).
std::vector<RejectedStretch> rejectedStretches(const FusionResult& f, bool given) {
  constexpr double kRtkStd = 0.05, kStretchSeconds = 3.0;
  constexpr std::size_t kStretchFixes = 5;
  const std::vector<const FixOutcome*> fixes = judgedFixes(f);
  std::vector<RejectedStretch> out;
  RejectedStretch run;
  auto close = [&] {
    if (run.fixes >= kStretchFixes && run.end - run.begin >= kStretchSeconds) out.push_back(run);
    run = RejectedStretch{};
  };
  for (const FixOutcome* o : fixes) {
    const bool kind =
        given ? o->std_given && o->std_dev.allFinite() && o->std_dev.head<2>().norm() < kRtkStd
              : !o->std_given;
    if (o->verdict != FixVerdict::kOutlier || !kind) {
      close();
      continue;
    }
    if (run.fixes == 0) run.begin = o->stamp;
    run.end = o->stamp;
    run.worst = std::max(run.worst, o->residual);
    ++run.fixes;
    run.rough += o->rough ? 1 : 0;
    run.height += apartInHeightAlone(o->error, o->weighedSigma()) ? 1 : 0;
  }
  close();
  std::sort(out.begin(), out.end(), [](const RejectedStretch& a, const RejectedStretch& b) {
    return a.end - a.begin > b.end - b.begin;
  });
  return out;
}

/// Whether the fixes of a stretch that claimed RTK precision agree with each other (fewer than
/// half of them rougher than they claim): its rejection is disputed between GNSS and SLAM.
bool disputed(const RejectedStretch& run) { return 2 * run.rough < run.fixes; }

/// The stretches of fixes that claimed RTK precision, agree with each other and were rejected.
std::vector<RejectedStretch> disputedStretches(const FusionResult& f) {
  std::vector<RejectedStretch> out = rejectedStretches(f, true);
  out.erase(std::remove_if(out.begin(), out.end(),
                           [](const RejectedStretch& run) { return !disputed(run); }),
            out.end());
  return out;
}

/// The stretches whose rejected fixes count among the local residuals of the pose sigmas where
/// they lie: the disputed ones, and those of fixes that came without a std-dev and do not
/// scatter beyond their noise either, whose fault is as open (a SLAM failure kept there: MulRan
/// with urban GNSS, within 2.45 sigma 84 / 66 / 72 / 62 / 76 / 88 % of the poses of its six
/// drives, so 93 / 71 / 78 / 68 / 99 / 90 %; KITTI's urban drives within a point of before).
std::vector<RejectedStretch> stretchesAgainstTheResult(const FusionResult& f) {
  std::vector<RejectedStretch> out = disputedStretches(f);
  for (const RejectedStretch& run : rejectedStretches(f, false)) {
    if (disputed(run)) out.push_back(run);
  }
  return out;
}

/// What a stretch of fixes that claimed RTK precision was: the GNSS's fault where its fixes
/// scatter more than they claim (they agree neither with each other nor with the SLAM's
/// short-term motion), else disputed between the two, and which side was followed and why.
std::string claimedVerdict(const RejectedStretch& run, const FusionResult& f) {
  if (!disputed(run)) {
    return " though their std-dev claimed RTK precision (under 5 cm): they scatter more than "
           "they claim and part from the SLAM's short-term motion, multipath or a false RTK "
           "fix, not a SLAM error; those fixes were left out";
  }
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << "; their std-dev claimed RTK precision (under 5 cm) and they agree with each other: "
       "disputed between the GNSS and the SLAM. The SLAM's shape was followed, since the "
       "stretch lies further from it than this SLAM's short-term errors reach (its excess over "
       "the fixes' noise is "
    << f.follow.excess
    << " m): multipath without scatter, or a SLAM that failed there (with fusion: false the "
       "GNSS is followed)";
  return s.str();
}

/// The three longest rejected stretches of a kind, one warning each; `what` follows the
/// stretch's span and fix count.
void warnRejectedStretches(const FusionResult& f, bool given, const std::string& what,
                           std::vector<std::string>& out) {
  const std::vector<RejectedStretch> runs = rejectedStretches(f, given);
  for (std::size_t k = 0; k < runs.size() && k < 3; ++k) {
    std::ostringstream s;
    s.setf(std::ios::fixed);
    s.precision(1);
    s << "GNSS from " << runs[k].begin << " to " << runs[k].end << " s (" << runs[k].fixes
      << " fixes" << (given ? ")" : ", no std-dev given)") << " up to " << runs[k].worst
      << " m off the fused trajectory";
    if (runs[k].height >= kHeightFixes) {
      s << " (" << runs[k].height << " of them in height alone, within " << kHeightApart
        << " sigma horizontally: as where the SLAM's height drifts)";
    }
    s << (given ? claimedVerdict(runs[k], f) : what);
    if (k == 2 && runs.size() > 3) s << " (and " << runs.size() - 3 << " more such stretches)";
    out.push_back(s.str());
  }
}

/// The stretches where precise fixes that agree with each other were followed however far the
/// SLAM's shape lay from them: the SLAM failed there. The three longest, one warning each.
void warnSlamFailures(const FusionResult& f, std::vector<std::string>& out) {
  std::vector<FusionResult::SlamFailure> runs = f.follow.slam_failures;
  std::sort(runs.begin(), runs.end(),
            [](const auto& a, const auto& b) { return a.end - a.begin > b.end - b.begin; });
  for (std::size_t k = 0; k < runs.size() && k < 3; ++k) {
    std::ostringstream s;
    s.setf(std::ios::fixed);
    s.precision(1);
    s << "SLAM failure: from " << runs[k].begin << " to " << runs[k].end
      << " s (SLAM clock) its shape lies up to " << runs[k].worst << " m from " << runs[k].fixes
      << (runs[k].claimed ? " fixes that claim RTK precision"
                          : " fixes whose scatter shows RTK precision (no std-dev given)")
      << " and agree with each other, with no step, gap or change of claim at either end: the "
         "GNSS was followed there. Check the SLAM there (its map may be distorted)";
    if (k == 2 && runs.size() > 3) s << " (and " << runs.size() - 3 << " more such stretches)";
    out.push_back(s.str());
  }
}

/// The runs of code-grade fixes at the drive's ends followed against the SLAM's shape
/// (drive_ends.h), one warning each.
void warnDriveEnds(const FusionResult& f, std::vector<std::string>& out) {
  for (const FusionResult::SlamFailure& run : f.drive_ends_followed) {
    std::ostringstream s;
    s.setf(std::ios::fixed);
    s.precision(1);
    s << "SLAM at an end of the drive: from " << run.begin << " to " << run.end
      << " s (SLAM clock) its shape lies " << run.worst << " m from the " << run.fixes
      << " fixes there, which agree with each other within their noise (" << run.precision
      << " m); nothing beyond them tells them wrong, so they were followed and the result eases "
         "back onto the SLAM's shape at the next fix. Check the SLAM there (a LiDAR odometry "
         "errs most in its first seconds)";
    out.push_back(s.str());
  }
}

/// The fixes that took part with their horizontal part alone, where at least kHeightFixes did:
/// how many, the longest run of them among the fixes that took part, and how far their heights
/// lie from the fused trajectory.
void warnHeightsLeftOut(const FusionResult& f, std::vector<std::string>& out) {
  if (f.heights_left_out < kHeightFixes) return;
  double worst = 0.0, begin = 0.0, end = 0.0, run_begin = 0.0;
  std::size_t longest = 0, run = 0;
  for (const FixOutcome* o : judgedFixes(f)) {
    if (!o->height_left_out) {
      run = 0;
      continue;
    }
    worst = std::max(worst, std::abs(o->error.z()));
    if (run++ == 0) run_begin = o->stamp;
    if (run > longest) longest = run, begin = run_begin, end = o->stamp;
  }
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << f.heights_left_out << " fixes took part with their horizontal part alone (the longest run "
    << longest << " from " << begin << " to " << end << " s): they agree with the fused "
    << "trajectory horizontally and lie up to " << worst << " m from it in height, as where the "
    << "SLAM's height drifts; the result keeps the SLAM's height there";
  out.push_back(s.str());
}

}  // namespace

namespace {

/// The clock's warnings: an offset the profiles could not tell from 0 but loosely, or not at
/// all, or not from a SLAM's own lag, or one told only loosely. Profiles that put it within
/// 15 ms of 0 confirm the stamps as given: nothing to warn of (report.json's clock says so).
void clockWarnings(const FusionResult& f, std::vector<std::string>& out) {
  constexpr double kLoose = 0.010;     // s: a looser 1-sigma is worth a word
  constexpr double kConfirms = 0.015;  // s: an offset within its noise of 0 at this 1-sigma
  const ClockEstimate& c = f.clock;
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  if (!f.time_offset_estimated && !c.reason.empty() && (!(c.sigma <= kConfirms) || c.within_lag)) {
    s << "clock: ";
    if (std::isfinite(c.sigma)) {
      s << "the speed and heading profiles put the GNSS " << 1e3 * c.offset << " +- "
        << 1e3 * c.sigma << " ms off the SLAM, ";
    }
    s << c.reason
      << ": the stamps are taken as given; if they are known to be off, give gnss_time_offset";
    out.push_back(s.str());
  } else if (f.time_offset_estimated && f.time_offset_sigma > kLoose) {
    s << "clock: the GNSS " << 1e3 * f.time_offset << " +- " << 1e3 * f.time_offset_sigma
      << " ms off the SLAM, loosely told by the speed and heading profiles (each millisecond "
         "is a centimetre along the track at 10 m/s); if the offset is known, give "
         "gnss_time_offset and max_time_offset 0";
    out.push_back(s.str());
  }
}

/// Where no lever arm was given and the drive shows the antenna away from the poses' origin.
void antennaWarning(const FusionResult& f, std::vector<std::string>& out) {
  if (!f.antenna_offset_estimated) return;
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(2);
  s << "lever arm: the drive puts the GNSS antenna at x " << f.antenna_offset.x() << ", y "
    << f.antenna_offset.y() << " m in the poses' body frame; none was given, so "
    << "the trajectory and the map lie as if the poses' origin were at the antenna: give "
       "lever_arm_x/y/z (or the TF) to place them at the origin itself";
  out.push_back(s.str());
}

}  // namespace

std::string sigmaWarning(const PoseSigmas& s, double max_sigma_h) {
  if (!(max_sigma_h > 0.0) || !(s.worst.sigma_h > max_sigma_h)) return "";
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(1);
  o << "uncertain: from " << s.worst.from << " to " << s.worst.to
    << " s (SLAM clock) the result may lie ";
  o.precision(3);
  o << s.worst.sigma_h << " m from the truth (1-sigma per axis; 95 % within 2.45 of it), beyond "
    << "max_sigma_h (" << max_sigma_h << " m); trajectory_sigma.txt gives every pose's";
  return o.str();
}

std::string controlPointShortfall(const ControlPointSelection& cp, std::size_t poses) {
  const std::size_t placed = cp.points.size() - std::min(cp.added, cp.points.size());
  if (10 * placed >= 9 * cp.requested) return "";
  return "control_points " + std::to_string(cp.requested) + " asked for, " +
         std::to_string(placed) + " placed: " + std::to_string(cp.skipped) +
         " found no usable GNSS in their stretch and the others fell on poses already taken " +
         "(at most one per pose; the drive has " + std::to_string(poses) + " poses)";
}

double shareFarFromPoses(const GeoreferenceResult& r, const WarpStats& map, double distance) {
  if (map.sample.empty() || r.poses.empty()) return 0.0;
  const PositionGrid grid(r.poses, distance);
  const auto far =
      std::count_if(map.sample.begin(), map.sample.end(),
                    [&](const Eigen::Vector3d& q) { return !grid.anyWithin(q, distance); });
  return static_cast<double>(far) / static_cast<double>(map.sample.size());
}

double sharePosesInMap(const GeoreferenceResult& r, const WarpStats& map, double distance) {
  if (map.sample.empty() || r.poses.empty()) return 0.0;
  const PositionGrid grid(map.sample, distance);
  const auto in = std::count_if(r.poses.begin(), r.poses.end(), [&](const Pose& p) {
    return grid.anyWithin(p.position, distance);
  });
  return static_cast<double>(in) / static_cast<double>(r.poses.size());
}

namespace {

constexpr double kFarFromPoses = 50.0;  // m: a LiDAR map holds most of its points nearer its drive

/// The warning for a map mostly far from the poses: a drive that made part of it (its poses
/// all inside the map), or a map in another frame.
std::string farMapWarning(const GeoreferenceResult& r, const WarpStats& map, double far,
                          const std::string& map_frame) {
  const auto percent = [](double share) {
    return std::to_string(std::lround(100.0 * share)) + " %";
  };
  if (sharePosesInMap(r, map, kFarFromPoses) > 0.95) {
    return "the poses cover " + percent(1.0 - far) + " of the map (within 50 m): is the drive " +
           "complete? (a bag still playing has given part of its poses) The map beyond them " +
           "has no control point near it";
  }
  return percent(far) + " of the map points lie more than 50 m from every pose: is the map in " +
         "the frame of the poses, '" + map_frame + "'? A map shifted or turned against its " +
         "poses is warped wrong";
}

/// "N of M fixes rejected" where more than four in five of the fixes the fusion judged were
/// rejected (a drive in an urban canyon may lose half of its fixes and still be bridged).
std::string mostFixesRejected(const GeoreferenceResult& r) {
  if (!r.fusion) return "";
  std::size_t judged = 0, rejected = 0;
  for (const FixOutcome& f : r.fusion->fixes) {
    judged += f.verdict == FixVerdict::kUsed || f.verdict == FixVerdict::kOutlier ? 1 : 0;
    rejected += f.verdict == FixVerdict::kOutlier ? 1 : 0;
  }
  if (5 * rejected <= 4 * judged) return "";
  return std::to_string(rejected) + " of " + std::to_string(judged) +
         " fixes rejected: the GNSS and the SLAM disagree on most of the drive";
}

/// Where not one pose is known within a hundred times max_sigma_h (50 m at its default): the
/// fixes that placed the result claim no more (a receiver whose every fix claims a kilometre
/// gave a sigma of 866 km and a result all the same). Ordinary GNSS of a metre or two leaves
/// its poses within a metre or so: uncertain, and warned of as such, not degraded.
std::string uncertainEverywhere(const GeoreferenceResult& r) {
  constexpr double kHopeless = 100.0;
  if (!(r.max_sigma_h > 0.0) || r.sigma.h.empty()) return "";
  const double least = *std::min_element(r.sigma.h.begin(), r.sigma.h.end());
  if (!(least > kHopeless * r.max_sigma_h)) return "";
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << "no pose is known within " << static_cast<int>(kHopeless) << " times max_sigma_h ("
    << kHopeless * r.max_sigma_h << " m): the least uncertain may lie " << least
    << " m from the truth (1-sigma per axis), as the GNSS it rests on claims";
  return s.str();
}

/// The rigid scale where it lies more than 5 % from 1.
std::string scaleOff(const GeoreferenceResult& r) {
  if (!(std::abs(r.scale - 1.0) > 0.05)) return "";
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << "the GNSS's track is " << r.scale << " times the SLAM's (rigid scale): beyond any SLAM's "
    << "scale error (are the GNSS of this drive and the poses in metres?)";
  return s.str();
}

}  // namespace

std::vector<std::string> degradedReasons(const GeoreferenceResult& r, const WarpStats* map,
                                         const std::string& map_frame) {
  std::vector<std::string> out;
  for (std::string reason : {mostFixesRejected(r), scaleOff(r), uncertainEverywhere(r)}) {
    if (!reason.empty()) out.push_back(std::move(reason));
  }
  if (const double far = map ? shareFarFromPoses(r, *map, kFarFromPoses) : 0.0; far > 0.5) {
    out.push_back(farMapWarning(r, *map, far, map_frame));
  }
  return out;
}

void checkDegraded(const GeoreferenceResult& r, const Params& params, const WarpStats* map,
                   const std::string& map_frame) {
  if (params.accept_degraded) return;
  const std::vector<std::string> reasons = degradedReasons(r, map, map_frame);
  if (reasons.empty()) return;
  std::string all;
  for (const auto& reason : reasons) all += (all.empty() ? "" : "; ") + reason;
  throw Error("the result cannot be right: " + all +
              " (accept_degraded true, or the tool's --accept-degraded, keeps it, marked "
              "degraded in report.json)");
}

namespace {

/// The fixes and poses dropped on the way in, by reason, in one line (none: empty).
std::string inputWarning(const GeoreferenceResult& r) {
  const std::string fixes = droppedInWords(r.gnss.dropped), poses = droppedInWords(r.pose_counts);
  if (fixes.empty() && poses.empty()) return "";
  std::string s = "input: ";
  if (!fixes.empty()) {
    s += std::to_string(r.gnss.dropped.total()) + " of " + std::to_string(r.gnss.received) +
         " fixes dropped: " + fixes;
  }
  if (!poses.empty()) {
    s += std::string(fixes.empty() ? "" : "; ") + std::to_string(r.pose_counts.dropped()) + " of " +
         std::to_string(r.pose_counts.received) + " poses dropped: " + poses;
  }
  return s + " (report.json: counts)";
}

}  // namespace

namespace {

std::vector<std::string> stampedWarnings(const GeoreferenceResult& r, const Params& params,
                                         const WarpStats* map, const std::string& map_frame);

/// Where a warning names a stretch by epoch stamps ("from 1317646096.5 to 1317646120.1 s"), the
/// seconds into the drive beside them: "(96.5-120.1 s into the drive)".
std::string withDriveSeconds(const std::string& w, double first) {
  static const std::regex kStretch(R"(from ([0-9]{7,}\.[0-9]+) to ([0-9]{7,}\.[0-9]+) s)");
  std::smatch m;
  if (!std::isfinite(first) || !std::regex_search(w, m, kStretch)) return w;
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << m.str(0) << " (" << std::stod(m.str(1)) - first << "-" << std::stod(m.str(2)) - first
    << " s into the drive)";
  return m.prefix().str() + s.str() + m.suffix().str();
}

}  // namespace

std::vector<std::string> resultWarnings(const GeoreferenceResult& r, const Params& params,
                                        const WarpStats* map, const std::string& map_frame) {
  std::vector<std::string> out = stampedWarnings(r, params, map, map_frame);
  const double first =
      r.poses.empty() ? std::numeric_limits<double>::quiet_NaN() : r.poses.front().stamp;
  for (std::string& w : out) w = withDriveSeconds(w, first);
  return out;
}

namespace {

std::vector<std::string> stampedWarnings(const GeoreferenceResult& r, const Params& params,
                                         const WarpStats* map, const std::string& map_frame) {
  std::vector<std::string> out;
  if (std::string in = inputWarning(r); !in.empty()) out.push_back(std::move(in));
  auto percent = [](double share) { return std::to_string(std::lround(100.0 * share)) + " %"; };
  const double poses_without =
      r.poses.empty() ? 0.0 : 1.0 - static_cast<double>(r.poses_matched) / r.poses.size();
  if (poses_without > params.max_uncovered_share) {
    out.push_back(percent(poses_without) + " of the poses have no GNSS: they are corrected by " +
                  "the nearest control points only, or by the rigid transform");
  }
  if (!r.threshold_lifted.empty()) out.push_back(r.threshold_lifted);
  // Seen only in a result kept with accept_degraded (or before the check).
  for (const auto& reason : degradedReasons(r, map, map_frame)) {
    out.push_back("degraded: " + reason);
  }
  if (map != nullptr && map->points > map->non_finite) {
    const double outside =
        static_cast<double>(map->outside) / static_cast<double>(map->points - map->non_finite);
    if (outside > params.max_uncovered_share) {
      out.push_back(percent(outside) + " of the map points lie beyond the GNSS coverage: they " +
                    "got the rigid transform only, without drift correction");
    }
  }
  if (std::string uncertain = sigmaWarning(r.sigma, params.max_sigma_h); !uncertain.empty()) {
    out.push_back(std::move(uncertain));
  }
  if (std::string cap = controlPointShortfall(r.control_points, r.poses.size()); !cap.empty()) {
    out.push_back(std::move(cap));
  }
  if (r.revisits.conflicting > 0) {
    std::ostringstream s;
    s.precision(3);
    s << r.revisits.conflicting << " control point pairs revisit places that the SLAM map puts "
      << "elsewhere on another pass (up to " << r.revisits.worst << " m) while the "
      << (r.method == Method::kFusion ? "fused trajectory" : "GNSS")
      << " puts them together: the SLAM is at fault there (a loop it never closed, or passes "
         "its loop closure did not merge); each pass keeps its own correction, but map points "
         "between the passes belong to both: close those loops in the SLAM";
    out.push_back(s.str());
  }
  if (r.fusion) clockWarnings(*r.fusion, out);
  if (r.fusion) antennaWarning(*r.fusion, out);
  if (r.fusion && r.fusion->time_offset_held) {
    const FusionResult& f = *r.fusion;
    std::ostringstream s;
    s.setf(std::ios::fixed);
    s.precision(4);
    s << "clock: the fit of positions put the GNSS " << f.time_offset_from_positions
      << " s off the SLAM, the speed profiles " << f.time_offset_from_speed << " +- "
      << f.time_offset_speed_sigma << " s; held at "
      << (f.time_offset == 0.0 ? "the stamps as given (no offset beyond the profiles' noise)"
                               : "the speed profiles'")
      << ": a SLAM shape error, as in fast turns, passes for an offset in a fit of positions";
    out.push_back(s.str());
  }
  if (r.fusion) {
    warnSlamFailures(*r.fusion, out);
    warnDriveEnds(*r.fusion, out);
    warnHeightsLeftOut(*r.fusion, out);
    warnRejectedStretches(*r.fusion, true, "", out);
    warnRejectedStretches(
        *r.fusion, false,
        ", which keeps the SLAM's shape there; those fixes were left out. Without a std-dev "
        "either may be wrong (multipath, GNSS drawn through an outage, or a SLAM that bent): "
        "check that stretch (with fusion: false the GNSS is followed)",
        out);
  }
  return out;
}

}  // namespace

std::string toString(Method m) { return m == Method::kFusion ? "fusion" : "gnss"; }

const Trajectory& resultPoses(const GeoreferenceResult& r) {
  return r.fusion && r.method == Method::kFusion ? r.fusion->poses : r.rubbersheet;
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

namespace {

/// Control points and sheet of the published method: the GNSS at the poses is the target.
void sheetFromGnss(const Params& params, GeoreferenceResult& r) {
  const std::vector<bool> usable = usablePoses(r.poses, r.gnss_at_pose, params);
  const Alignment a = alignTrajectory(r.poses, r.gnss_at_pose, usable, params);
  r.T_enu_map = a.T_enu_map;
  r.scale = a.scale;
  r.aligned = transformed(r.poses, r.T_enu_map);
  SheetOptions options = sheetOptions(params);
  options.targets_are_fixes = true;
  r.cuboid_enu = makeCuboid(r.aligned, r.gnss_at_pose, options);
  r.control_points =
      chooseControlPoints(r.poses, r.gnss_at_pose, usable, r.T_enu_map, r.cuboid_enu, options);
  r.sheet = buildSheet(r.control_points, {}, r.T_enu_map, r.cuboid_enu);
}

/// The fixes a GNSS control point may come from: within the std-dev threshold, outside the
/// excluded ranges.
std::vector<GnssPoint> controlPointFixes(const Params& params, const GeoreferenceResult& r) {
  std::vector<GnssPoint> out;
  for (const GnssPoint& g : r.gnss.points) {
    const bool excluded = std::any_of(params.excluded_ranges.begin(), params.excluded_ranges.end(),
                                      [&](const TimeRange& t) { return t.contains(g.stamp); });
    if (!excluded && !(g.stdDevH() > params.stddev_threshold)) out.push_back(g);
  }
  return out;
}

/// What a reported 1-sigma holds beyond the white noise `white` (0 where not finite).
double beyond(double reported, double white) {
  const double d = reported * reported - white * white;
  return std::isfinite(d) && d > 0.0 ? std::sqrt(d) : 0.0;
}

}  // namespace

std::vector<SigmaFix> sigmaFixes(const GeoreferenceResult& r, const Params& params) {
  std::vector<SigmaFix> out;
  if (r.fusion && r.method == Method::kFusion) {
    const std::vector<FixOutcome>& fixes = r.fusion->fixes;
    const std::vector<RejectedStretch> disputes = stretchesAgainstTheResult(*r.fusion);
    for (std::size_t j = 0; j < fixes.size(); ++j) {
      const FixOutcome& f = fixes[j];
      const bool disputed =
          f.verdict == FixVerdict::kOutlier &&
          std::any_of(disputes.begin(), disputes.end(), [&](const RejectedStretch& d) {
            return f.stamp >= d.begin && f.stamp <= d.end;
          });
      if (f.verdict != FixVerdict::kUsed && !disputed) continue;
      SigmaFix s{f.stamp + r.fusion->time_offset, f.position, f.std_dev.x(), f.std_dev.z()};
      s.disputed = disputed;
      if (f.std_given && j < r.gnss.points.size()) {
        const Eigen::Vector3d& reported = r.gnss.points[j].std_dev;
        s.shared_h = beyond(reported.head<2>().norm() / std::sqrt(2.0), s.std_h);
        s.shared_v = beyond(reported.z(), s.std_v);
      }
      out.push_back(s);
    }
    return out;
  }
  const double estimated = r.clock_offset - params.gnss_time_offset;
  for (const GnssPoint& g : controlPointFixes(params, r)) {
    out.push_back({g.stamp + estimated, g.position, g.std_dev.head<2>().norm() / std::sqrt(2.0),
                   g.std_dev.z()});
  }
  return out;
}

double estimatedClockSigma(const GeoreferenceResult& r) {
  double sigma = std::numeric_limits<double>::infinity();
  const auto take = [&](double s) {
    if (std::isfinite(s) && s > 0.0) sigma = std::min(sigma, s);
  };
  if (r.fusion && r.fusion->time_offset != 0.0) {
    if (r.fusion->clock.loose) {
      take(r.fusion->time_offset_sigma);  // the profiles knew it loosely, the fit decided it
    } else if (r.fusion->time_offset_held) {
      // The speed profile's offset alone, which a SLAM's own lag moves (MulRan: 8-20 ms from
      // the truth, at a 1-sigma of 3.5-5.3 ms; within 2.45 sigma 12.6-56 % of KAIST_03, KAIST_02
      // and DCC_03's poses with RTK GNSS, its sigma alone).
      take(std::hypot(r.fusion->time_offset_speed_sigma, kSlamLag));
    } else {
      take(r.fusion->time_offset_speed_sigma);
      if (!r.fusion->clock.disagree) take(r.fusion->clock.heading.sigma);
      // The fit of positions refines the offset within the profiles' sigma, but a SLAM's shape
      // error (a loop closure's snap, a lag of its own) moves it as well as the clock does: the
      // truth may lie anywhere between it and the speed profile, which no shape error moves, and
      // half their distance counts. loop_closures seeds 2 and 3, 3.5 and 3.4 ms off: 0.9 and
      // 1.2 ms from the heading profile alone, 1.7 and 2.2 ms so. In full, KITTI 01 RTK with its
      // stamps 0.3 s off (2.8 ms, the speed profile 12 ms off) had a median sigma 4.3 times its
      // RMSE; so 2.4 times.
      const double moved = r.fusion->time_offset - r.fusion->time_offset_from_speed;
      if (std::isfinite(sigma) && std::isfinite(moved)) sigma = std::hypot(sigma, 0.5 * moved);
    }
  } else if (!r.fusion && r.speed_clock && std::isfinite(r.clock_offset_sigma)) {
    take(r.speed_clock->sigma);
  }
  return std::isfinite(sigma) ? sigma : 0.0;
}

namespace {

/// Of the speed profiles' sigma, the clock's where the fusion held it at the stamps as given:
/// calibrated on the urban drives, whose imprecise fixes hide it. MulRan's (true offsets 38-58
/// ms, the profiles' sigma 37-47 ms) from 67-78 % of DCC_03, KAIST_02 and KAIST_03's poses
/// within 2.45 sigma_h to 77-83 %; KITTI's (true offset 0) from 97.6 % pooled to 98.9 %. In full,
/// every KITTI urban drive lay 100 % within.
constexpr double kHeldClockShare = 0.5;

/// m: what an estimated antenna offset is off along the track beyond its own sigma (which
/// takes the fixes' noise as white): on the six MulRan RTK drives the trajectory's mean error
/// along the track, 0.00-0.09 m, is the offset's and the clock's, traded for each other.
constexpr double kAntennaSystematic = 0.08;

/// SigmaContext::antenna_sigma: 0 where none was estimated.
double estimatedAntennaSigma(const GeoreferenceResult& r) {
  if (!r.fusion || r.method != Method::kFusion || !r.fusion->antenna_offset_estimated) return 0.0;
  return std::hypot(r.fusion->antenna_offset_sigma, kAntennaSystematic);
}

/// Where the fusion held the clock at the stamps as given, the 1-sigma it is known to (see
/// SigmaContext::held_clock_sigma); 0 where it was estimated or not asked for.
double heldClockSigma(const GeoreferenceResult& r) {
  if (!r.fusion || r.fusion->time_offset != 0.0) return 0.0;
  const double s = r.fusion->time_offset_speed_sigma;
  return std::isfinite(s) && s > 0.0 ? kHeldClockShare * s : 0.0;
}

/// Without the fusion, the clock offset the speed profiles show (clock_offset.h), from the
/// fixes a control point may come from: applied on top of gnss_time_offset where they show one
/// beyond kSignificant sigmas of zero and of a SLAM's own lag (beyondSlamLag: at least 37.5 ms;
/// max_time_offset 0: none asked for). Nothing refines it, and the stamps as given are the
/// better guess for an offset within the noise: monza, whose true offset is 0, every 4th fix
/// held out: -0.0032 +- 0.0029 s, applied MAE 0.220 -> 0.228 m.
void estimateClockWithoutFusion(const Params& params, GeoreferenceResult& r) {
  constexpr double kSignificant = 3.0;
  r.clock_offset = params.gnss_time_offset;
  if (!(params.max_time_offset > 0.0)) return;
  r.speed_clock =
      estimateClockOffset(r.poses, controlPointFixes(params, r), params.max_time_offset);
  const ClockOffsetEstimate& c = *r.speed_clock;
  if (!c.observable || !beyondSlamLag(c.offset, c.sigma, kSignificant)) return;
  r.clock_offset += c.offset;
  r.clock_offset_sigma = c.sigma;
  matchGnssAt(c.offset, params, r);
}

/// The fused poses oriented as the keyframe graph left them (FusionResult::heading_turn undone):
/// the sheet's points beside the route are placed with these. With the turned headings the
/// sheet's maps on MulRan moved by -0.52 m (Riverside_02 away from revisits, better) to +0.05 m,
/// and one held-out fix of a2rl by 3 cm, past the simple way's MAX: the sheet's rounds move
/// with them far from the turned poses (85 s on a2rl).
Trajectory graphOriented(const FusionResult& f) {
  Trajectory t = f.poses;
  for (std::size_t i = 0; i < t.size() && i < f.heading_turn.size(); ++i) {
    if (f.heading_turn[i] == 0.0) continue;
    const Eigen::AngleAxisd back(-f.heading_turn[i], Eigen::Vector3d::UnitZ());
    t[i].orientation = (back * t[i].orientation).normalized();
  }
  return t;
}

/// Control points and sheet from the fused trajectory, with points beside and above it.
void sheetFromFusion(const Params& params, const CancelToken& cancel, GeoreferenceResult& r,
                     StageSeconds& seconds, Stopwatch& watch) {
  const Alignment start = robustAlignment(r.poses, r.gnss_at_pose, params);
  seconds.alignment = watch.lap();
  r.fusion = fuseTrajectory(r.poses, r.gnss.points, start.T_enu_map, fusionOptions(params), cancel);
  r.method = Method::kFusion;
  r.clock_offset = params.gnss_time_offset + r.fusion->time_offset;
  r.clock_offset_sigma = r.fusion->time_offset_estimated ? r.fusion->time_offset_sigma
                                                         : std::numeric_limits<double>::quiet_NaN();
  // A fix stamped t was taken at SLAM time t + offset: the GNSS the poses are compared with
  // (the metrics, trajectory_gnss.txt, the revisit check) is taken at their own instant.
  if (r.fusion->time_offset != 0.0) matchGnssAt(r.fusion->time_offset, params, r);
  const Alignment a = alignToFused(r.poses, r.fusion->poses);
  r.T_enu_map = a.T_enu_map;
  r.scale = a.scale;
  r.aligned = transformed(r.poses, r.T_enu_map);
  seconds.fusion = watch.lap();
  const std::vector<std::optional<GnssPoint>> targets = fusedTargets(*r.fusion);
  const std::vector<bool> usable = usablePoses(r.poses, targets, params);
  r.cuboid_enu = makeCuboid(r.aligned, targets, sheetOptions(params));
  r.control_points = chooseControlPoints(r.poses, targets, usable, r.T_enu_map, r.cuboid_enu,
                                         sheetOptions(params));
  // Where the SLAM jumped, its orientation there is no better than its position: no points
  // beside those control points.
  std::vector<bool> steady(r.poses.size());
  for (std::size_t i = 0; i < steady.size(); ++i) steady[i] = !r.fusion->jumped[i];
  // The sheet follows the fused trajectory to its first and last poses, also where no fix
  // speaks (a receiver that starts late or stops early): the fused trajectory carries the SLAM
  // on there with the drift it showed at the nearest fixes, where a sheet left to its cuboid
  // beyond the fixes went metres astray (`open_gnss_late`: 25 m where the fused trajectory was
  // 1.1 m off the truth). The control points' spread stays within the fixes' span.
  const std::vector<std::optional<GnssPoint>> faithful =
      fusedTargets(*r.fusion, std::numeric_limits<double>::infinity());
  const std::vector<bool> reach = usablePoses(r.poses, faithful, params);
  const SheetWithBeside s =
      buildFaithfulSheet(r.control_points, r.poses, graphOriented(*r.fusion), faithful, reach,
                         r.T_enu_map, r.cuboid_enu, sheetOptions(params), steady);
  r.sheet = s.sheet;
  r.beside = s.beside;
  r.beside_folding = s.folding;
  r.control_points.added = s.added;
}

/// The parameters the run goes on with: with the fusion, a std-dev threshold that leaves fewer
/// than a quarter of the fixes with a known std-dev is lifted (the fusion weighs every fix by
/// its std-dev: ordinary 1-3 m GNSS works with the defaults), and the result says so.
Params thresholdInUse(const Params& params, GeoreferenceResult& r) {
  if (!params.fusion) return params;
  std::vector<double> h;
  std::size_t within = 0;
  for (const auto& g : r.gnss.points) {
    if (!std::isfinite(g.stdDevH())) continue;
    h.push_back(g.stdDevH());
    within += g.stdDevH() <= params.stddev_threshold ? 1 : 0;
  }
  if (h.empty() || 4 * within >= h.size()) return params;
  std::nth_element(h.begin(), h.begin() + h.size() / 2, h.end());
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  s << "stddev_threshold " << params.stddev_threshold << " m leaves " << within << " of "
    << h.size() << " fixes (median horizontal std-dev " << h[h.size() / 2]
    << " m): the fusion weighs every fix by its std-dev instead";
  r.threshold_lifted = s.str();
  Params lifted = params;
  lifted.stddev_threshold = std::numeric_limits<double>::infinity();
  return lifted;
}

/// The SLAM's white jitter from pose to pose (jitter_smoothing.h), which the sheet and the fused
/// trajectory carry from the poses as every smooth correction does: measured, and with
/// smooth_jitter taken out of both, but where the SLAM jumped.
void smoothTrajectories(const Params& params, GeoreferenceResult& r) {
  // The fixes at their stamps as given: those stamped as a pose is (resampled at the poses,
  // or written with the same made-up clock) share the stamps' errors with it.
  r.jitter = measureJitter(r.aligned, r.gnss.points);
  r.jitter_left.assign(r.poses.size(), r.jitter.seen ? r.jitter.white : 0.0);
  if (!params.smooth_jitter) {
    r.jitter.half_width = 0;  // measured, not smoothed
    return;
  }
  const std::vector<bool> keep = r.fusion ? r.fusion->jumped : std::vector<bool>{};
  const std::vector<double> left = smoothJitter(r.rubbersheet, r.jitter.half_width, keep);
  if (r.fusion) smoothJitter(r.fusion->poses, r.jitter.half_width, keep);
  for (std::size_t i = 0; i < left.size(); ++i) r.jitter_left[i] *= left[i];
}

}  // namespace

GeoreferenceResult georeference(const DriveInput& input, const Params& given,
                                const CancelToken& cancel) {
  if (const std::string bad = given.validate(); !bad.empty()) throw Error("parameters: " + bad);
  if (!input.fixes.empty() && !input.local_gnss.empty()) {
    throw Error("input: give geodetic fixes or local GNSS points, not both");
  }
  GeoreferenceResult r;
  Stopwatch watch;
  prepareInput(input, given, r);
  r.seconds.gnss = watch.lap();
  const Params params = thresholdInUse(given, r);
  matchGnss(params, r);
  if (!input.fixes.empty()) {
    checkLatLonOrder(input.fixes, r.poses, rigidFitMedian(r.poses, r.gnss_at_pose),
                     gnssOptions(params), interpolationOptions(params));
  }
  r.seconds.interpolation = watch.lap();
  if (params.fusion) {
    sheetFromFusion(params, cancel, r, r.seconds, watch);
    r.seconds.control_points = watch.lap();
  } else {
    estimateClockWithoutFusion(params, r);
    sheetFromGnss(params, r);
    r.seconds.control_points = watch.lap();
  }
  cancel.check("georeferencing");

  const bool fused = r.fusion && r.method == Method::kFusion;
  r.rubbersheet = warpTrajectory(*r.sheet, r.poses, fused ? &r.fusion->poses : nullptr);
  smoothTrajectories(params, r);
  const Eigen::Vector3d lever(params.lever_arm_x, params.lever_arm_y, params.lever_arm_z);
  r.metrics_aligned = deviationFromGnss(r.aligned, r.gnss_at_pose, lever);
  r.metrics_rubbersheet = deviationFromGnss(r.rubbersheet, r.gnss_at_pose, lever);
  if (r.fusion && r.method == Method::kFusion) {
    std::vector<double> d;
    for (std::size_t i = 0; i < r.poses.size(); ++i) {
      d.push_back((r.rubbersheet[i].position - r.fusion->poses[i].position).norm());
    }
    r.metrics_fused = errorStats(d);
  }
  for (const auto& cp : r.control_points.points) {
    r.residual_aligned.push_back((r.aligned[cp.pose_index].position - cp.target).norm());
    r.residual_rubbersheet.push_back((r.rubbersheet[cp.pose_index].position - cp.target).norm());
  }
  r.revisits = checkRevisits(r.control_points, r.poses, r.T_enu_map, r.gnss_at_pose);
  r.seconds.trajectory_warp = watch.lap();
  SigmaContext sigma_context;
  sigma_context.fused = r.fusion && r.method == Method::kFusion ? &r.fusion->poses : nullptr;
  sigma_context.clock_sigma = estimatedClockSigma(r);
  sigma_context.held_clock_sigma = heldClockSigma(r);
  sigma_context.antenna_sigma = estimatedAntennaSigma(r);
  sigma_context.lever_arm = r.fusion ? r.fusion->lever_arm : lever;
  sigma_context.jitter = &r.jitter_left;
  sigma_context.slam_white = r.jitter.seen ? r.jitter.white : 0.0;
  r.sigma = poseSigmas(r.rubbersheet, r.aligned, sigmaFixes(r, params), sigma_context);
  r.max_sigma_h = params.max_sigma_h;
  // A control point on the fused trajectory takes the sigma of its pose (3D) as its std-dev.
  if (r.method == Method::kFusion) {
    for (auto& cp : r.control_points.points) {
      const double h = r.sigma.h[cp.pose_index], v = r.sigma.v[cp.pose_index];
      cp.std_dev = std::sqrt(2.0 * h * h + v * v);
    }
  }
  r.map_sigma =
      expectedMapSigma(r.poses, r.rubbersheet, r.sigma, *r.sheet, pointSigmaModel(params));
  r.seconds.sigma = watch.lap();
  return r;
}

}  // namespace flexcloud
