#include "flexcloud/fusion/drive_ends.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "flexcloud/fusion/precise_follow.h"
#include "follow_series.h"

namespace flexcloud {
namespace {

/// Fewer rejected fixes at an end are outliers like any other.
constexpr std::size_t kEndFixes = 3;
/// The run's errors agree with each other where their mean square about their mean is at most
/// this many times their own variance (per axis).
constexpr double kAgree = 2.0;

/// Rejected, and not the refinement's (precise_follow.h): the fixes it takes, within
/// FollowOptions::max_std, it judges by their own evidence.
bool codeGradeRejected(const FusionResult& f, const FixOutcome& o) {
  return o.verdict == FixVerdict::kOutlier && o.error.allFinite() &&
         follow::ownStd(f, o).x() > FollowOptions{}.max_std;
}

/// How many of `order`'s first fixes are code-grade and rejected.
std::size_t leadingRun(const FusionResult& f, const std::vector<std::size_t>& order) {
  std::size_t n = 0;
  while (n < order.size() && codeGradeRejected(f, f.fixes[order[n]])) ++n;
  return n;
}

/// A run at an end: what it tells (FusionResult::drive_ends_followed) and its mean horizontal
/// error from the result.
struct EndRun {
  FusionResult::SlamFailure told;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
};

/// The run's mean horizontal error and its horizontal 1-sigma (the root mean of the fixes'
/// variances as weighed), where its errors agree with each other; nothing where they do not.
std::optional<EndRun> agreeingRun(const FusionResult& f, const std::vector<std::size_t>& run) {
  EndRun out;
  double var = 0.0;
  for (std::size_t j : run) {
    out.mean += f.fixes[j].error.head<2>();
    var += std::pow(f.fixes[j].weighedSigma().x(), 2);
  }
  const auto n = static_cast<double>(run.size());
  out.mean /= n;
  double scatter = 0.0;  // in the fixes' own variances, both axes
  for (std::size_t j : run) {
    scatter += (f.fixes[j].error.head<2>() - out.mean).squaredNorm() /
               std::pow(f.fixes[j].weighedSigma().x(), 2);
  }
  if (!(scatter <= kAgree * 2.0 * (n - 1.0))) return std::nullopt;
  out.told.worst = out.mean.norm();
  out.told.precision = std::sqrt(var / n);
  out.told.fixes = run.size();
  out.told.claimed = false;
  return out;
}

/// Every pose moved by `mean`: in full up to `at_run` (SLAM clock), not at all from
/// `at_followed` on (either side of it), linearly between.
void movePoses(Trajectory& poses, const Eigen::Vector2d& mean, double at_run, double at_followed) {
  for (Pose& p : poses) {
    const double u = (at_followed - p.stamp) / (at_followed - at_run);
    const double w = std::clamp(std::isfinite(u) ? u : 0.0, 0.0, 1.0);
    p.position.head<2>() += w * mean;
  }
}

/// The run's fixes used, their errors from the poses moved by `mean`.
void takeIn(FusionResult& f, const std::vector<std::size_t>& run, const Eigen::Vector2d& mean) {
  for (std::size_t j : run) {
    FixOutcome& o = f.fixes[j];
    o.error.head<2>() -= mean;
    o.residual = o.error.norm();
    o.weight = 1.0;
    o.verdict = FixVerdict::kUsed;
  }
  f.used += run.size();
  f.outliers -= run.size();
}

/// Follows the run of `order`'s first fixes where it is one (see drive_ends.h). `order` runs
/// from the end at hand inwards.
void followEnd(FusionResult& f, const std::vector<std::size_t>& order) {
  const std::size_t n = leadingRun(f, order);
  if (n < kEndFixes || n >= order.size()) return;
  const std::vector<std::size_t> run(order.begin(), order.begin() + static_cast<long>(n));
  std::optional<EndRun> end = agreeingRun(f, run);
  if (!end) return;
  // From the run's innermost fix to the first the result follows: eased from all to none.
  const double at_run = f.fixes[run.back()].stamp + f.time_offset;
  const double at_outer = f.fixes[run.front()].stamp + f.time_offset;
  movePoses(f.poses, end->mean, at_run, f.fixes[order[n]].stamp + f.time_offset);
  takeIn(f, run, end->mean);
  end->told.begin = std::min(at_run, at_outer);
  end->told.end = std::max(at_run, at_outer);
  f.drive_ends_followed.push_back(end->told);
}

}  // namespace

void followTheDrivesEnds(FusionResult& f) {
  f.drive_ends_followed.clear();
  std::vector<std::size_t> order = judgedByStamp(f);
  followEnd(f, order);
  std::reverse(order.begin(), order.end());
  followEnd(f, order);
}

}  // namespace flexcloud
