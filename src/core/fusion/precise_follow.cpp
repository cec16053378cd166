#include "flexcloud/fusion/precise_follow.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "flexcloud/metrics.h"
#include "follow_em.h"
#include "follow_series.h"

namespace flexcloud {
namespace {

using follow::Refinement;
using follow::Series;
using follow::Vec3;

constexpr double kMoved = 1e-3;  // m: a pose moved by less counts as kept
/// m of path either side of a pose over which its direction of travel is read (at 5 m KITTI's
/// headings were up to 0.7 degrees worse at p95: its paths' short bends taken for turns).
constexpr double kTurnReach = 25.0;
/// s: a longer chord spans a stop, where the correction changes with time, not with the path
/// (KITTI 07, 12 s at a stop: its pitch 2.4 degrees off).
constexpr double kTurnSpan = 10.0;
/// A turn within this many sigmas of the SLAM's short-term wander is no turn. KITTI's turns lie
/// at that level and do not correlate with its headings' errors (-0.3 to -0.1); its headings are
/// unchanged at 2 and at 3, where KAIST_02's p95 is 0.78 and 0.87 degrees.
constexpr double kTurnSigmas = 2.0;

/// The correction at instant t: linear between the fixes around it, held beyond the ends.
Vec3 correctionAt(const Series& s, const Refinement& e, double t, std::size_t& k) {
  while (k + 1 < s.size() && s.t[k + 1] <= t) ++k;
  if (t <= s.t.front()) return e.correction(0);
  if (k + 1 >= s.size()) return e.correction(s.size() - 1);
  const double span = s.t[k + 1] - s.t[k];
  const double u = span > 0.0 ? (t - s.t[k]) / span : 0.0;
  return (1.0 - u) * e.correction(k) + u * e.correction(k + 1);
}

void moveThePoses(FusionResult& f, const Series& s, const Refinement& e) {
  std::size_t k = 0, j = 0;
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    Pose& p = f.poses[i];
    const Vec3 c = correctionAt(s, e, p.stamp, k);
    p.position += c;
    if (c.norm() > kMoved) ++f.detail_poses;
    f.detail_max_shift = std::max(f.detail_max_shift, c.norm());
    // A pose next to a step the SLAM jumped at.
    while (j + 1 < s.size() && s.t[j + 1] <= p.stamp) ++j;
    f.jumped[i] = e.jumps()[j] > 0.5 || (j + 1 < s.size() && e.jumps()[j + 1] > 0.5);
  }
}

/// The first index at least `reach` of path before i (0 if none) and after it (the last).
std::pair<std::size_t, std::size_t> chordAround(const std::vector<double>& path, std::size_t i,
                                                std::size_t& lo, std::size_t& hi, double reach) {
  while (lo < i && path[i] - path[lo + 1] >= reach) ++lo;
  hi = std::max(hi, i);
  while (hi + 1 < path.size() && path[hi] - path[i] < reach) ++hi;
  return {lo, hi};
}

/// The angle by which `x` exceeds `by` in size (0 within it): a turn within what the SLAM's
/// own short-term wander explains is no turn.
double beyond(double x, double by) { return std::copysign(std::max(0.0, std::abs(x) - by), x); }

/// Turns each pose's heading as the correction turned its path (FusionResult::heading_turn):
/// its chord of travel (kTurnReach of path either side, within kTurnSpan) before the correction
/// and after it; the part beyond kTurnSigmas of what the SLAM's short-term wander (q_h, m^2 per
/// m) turns such a chord by. The keyframe graph's orientations fit its own path; where the fixes
/// bent it further, the heading follows (MulRan KAIST_02: 1.2-1.8 degrees off for 5-20 s after
/// turns, where the path's direction was within 0.3; KITTI's paths bend by the SLAM's wander
/// alone, and its headings stay as they were).
void turnWithThePath(FusionResult& f, const std::vector<Vec3>& before, double q_h) {
  std::vector<double> path(before.size(), 0.0);
  for (std::size_t i = 1; i < before.size(); ++i) {
    path[i] = path[i - 1] + (before[i] - before[i - 1]).norm();
  }
  Trajectory& poses = f.poses;
  f.heading_turn.assign(poses.size(), 0.0);
  std::size_t lo = 0, hi = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const auto [a, b] = chordAround(path, i, lo, hi, kTurnReach);
    const Vec3 was = before[b] - before[a], now = poses[b].position - poses[a].position;
    const double h0 = was.head<2>().norm(), h1 = now.head<2>().norm();
    if (!(h0 >= kTurnReach && h1 >= kTurnReach)) continue;
    if (!(poses[b].stamp - poses[a].stamp <= kTurnSpan)) continue;
    const double turn =
        std::atan2(was.x() * now.y() - was.y() * now.x(), was.head<2>().dot(now.head<2>()));
    f.heading_turn[i] = beyond(turn, kTurnSigmas * std::sqrt(q_h / h0));
    poses[i].orientation =
        (Eigen::AngleAxisd(f.heading_turn[i], Vec3::UnitZ()) * poses[i].orientation).normalized();
  }
}

void judgeTheFixes(FusionResult& f, const Series& s, const Refinement& e) {
  std::size_t k = 0;
  for (std::size_t j = 0; j < s.size(); ++j) {
    FixOutcome& x = f.fixes[s.fix[j]];
    const Pose p = follow::poseAt(f.poses, s.t[j], k);
    const bool was = x.verdict == FixVerdict::kUsed;
    x.weight = e.weights()[j];
    x.verdict = x.weight >= 0.5 ? FixVerdict::kUsed : FixVerdict::kOutlier;
    x.error = x.position - (p.position + p.orientation * f.lever_arm);
    x.residual = x.error.norm();
    if (!was && x.verdict == FixVerdict::kUsed) ++f.follow.taken_back;
    if (x.verdict == FixVerdict::kOutlier) ++f.follow.rejected;
  }
  f.used = f.outliers = 0;
  for (const auto& x : f.fixes) {
    f.used += x.verdict == FixVerdict::kUsed;
    f.outliers += x.verdict == FixVerdict::kOutlier;
  }
}

/// The runs the refinement followed though far from the SLAM's shape (Refinement::followed).
std::vector<FusionResult::SlamFailure> slamFailures(const Series& s, const Refinement& e) {
  std::vector<FusionResult::SlamFailure> out;
  const std::vector<bool>& followed = e.followed();
  for (std::size_t j = 0; j < s.size(); ++j) {
    if (!followed[j]) continue;
    if (j == 0 || !followed[j - 1]) out.push_back({s.t[j], s.t[j], 0.0, 0.0, 0, true});
    FusionResult::SlamFailure& run = out.back();
    run.end = s.t[j];
    run.worst = std::max(run.worst, s.r[j].head<2>().norm());
    const bool claimed = std::isfinite(s.claim[j]);
    run.precision = std::max(run.precision, claimed ? s.claim[j] : std::sqrt(s.var[j].x()));
    run.claimed = run.claimed && claimed;
    ++run.fixes;
  }
  return out;
}

void medianJitter(FusionResult& f) {
  std::vector<double> h, v;
  for (const auto& x : f.fixes) {
    if (x.verdict != FixVerdict::kUsed) continue;
    h.push_back(x.slam_jitter.x());
    v.push_back(x.slam_jitter.z());
  }
  if (h.empty()) return;
  f.slam_jitter_h = median(std::move(h));
  f.slam_jitter_v = median(std::move(v));
}

}  // namespace

void followPreciseGnss(FusionResult& f, const FollowOptions& options) {
  medianJitter(f);
  f.jumped.assign(f.poses.size(), false);
  f.detail_poses = 0;
  f.detail_max_shift = 0.0;
  f.follow = {};
  if (f.poses.size() < 2) return;
  const Series all = follow::gather(f, options);
  std::vector<Vec3> positions;
  for (std::size_t j : all.fix) positions.push_back(f.fixes[j].position);
  const Series s = follow::keepTheSmooth(all, positions);
  for (std::size_t j : all.fix) f.fixes[j].rough = true;
  for (std::size_t j : s.fix) f.fixes[j].rough = false;
  if (s.size() < options.min_fixes) return;
  std::vector<double> start;
  for (std::size_t j : s.fix) start.push_back(f.fixes[j].weight);
  Refinement e(s, options);
  e.run(follow::detectJumps(s), start);
  f.follow.fixes = s.size();
  f.follow.q_h = e.q(0);
  f.follow.q_v = e.q(1);
  f.follow.excess = e.excess();
  for (double p : e.jumps()) f.follow.jumps += p > 0.5;
  for (bool l : e.locked()) f.follow.locked += l;
  f.follow.slam_failures = slamFailures(s, e);
  std::vector<Vec3> before;
  for (const Pose& p : f.poses) before.push_back(p.position);
  moveThePoses(f, s, e);
  turnWithThePath(f, before, e.q(0));
  judgeTheFixes(f, s, e);
}

}  // namespace flexcloud
