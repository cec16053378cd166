#include "flexcloud/fusion/drive_ends.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

namespace flexcloud {
namespace {

/// Fewer rejected fixes at an end are outliers like any other.
constexpr std::size_t kEndFixes = 3;
/// m: fixes whose own horizontal std-dev is at most this are the refinement's
/// (FollowOptions::max_std), which judges them by their own evidence.
constexpr double kPreciseStd = 0.1;
/// The run's errors agree with each other where their mean square about their mean is at most
/// this many times their own variance (per axis).
constexpr double kAgree = 2.0;

/// The fixes that took part (used or rejected), by stamp.
std::vector<std::size_t> takingPart(const FusionResult& f) {
  std::vector<std::size_t> out;
  for (std::size_t j = 0; j < f.fixes.size(); ++j) {
    const FixVerdict v = f.fixes[j].verdict;
    if (v == FixVerdict::kUsed || v == FixVerdict::kOutlier) out.push_back(j);
  }
  std::stable_sort(out.begin(), out.end(), [&](std::size_t a, std::size_t b) {
    return f.fixes[a].stamp < f.fixes[b].stamp;
  });
  return out;
}

bool codeGradeRejected(const FixOutcome& o) {
  return o.verdict == FixVerdict::kOutlier && o.error.allFinite() &&
         o.std_dev.head<2>().maxCoeff() > kPreciseStd;
}

/// How many of `order`'s first fixes are code-grade and rejected.
std::size_t leadingRun(const FusionResult& f, const std::vector<std::size_t>& order) {
  std::size_t n = 0;
  while (n < order.size() && codeGradeRejected(f.fixes[order[n]])) ++n;
  return n;
}

/// The run's mean horizontal error and its horizontal 1-sigma (the root mean of the fixes'
/// variances as weighed), where its errors agree with each other; nothing where they do not.
std::optional<FusionResult::SlamFailure> agreeingRun(const FusionResult& f,
                                                     const std::vector<std::size_t>& run) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  double var = 0.0;
  for (std::size_t j : run) {
    mean += f.fixes[j].error.head<2>();
    var += std::pow(f.fixes[j].weighedSigma().x(), 2);
  }
  const auto n = static_cast<double>(run.size());
  mean /= n;
  var /= n;
  double scatter = 0.0;  // in the fixes' own variances, both axes
  for (std::size_t j : run) {
    scatter += (f.fixes[j].error.head<2>() - mean).squaredNorm() /
               std::pow(f.fixes[j].weighedSigma().x(), 2);
  }
  if (!(scatter <= kAgree * 2.0 * (n - 1.0))) return std::nullopt;
  FusionResult::SlamFailure out;
  out.worst = mean.norm();
  out.precision = std::sqrt(var);
  out.fixes = run.size();
  out.claimed = false;
  return out;
}

/// Follows the run of `order`'s first fixes where it is one (see drive_ends.h). `order` runs
/// from the end at hand inwards.
void followEnd(FusionResult& f, const std::vector<std::size_t>& order) {
  const std::size_t n = leadingRun(f, order);
  if (n < kEndFixes || n >= order.size()) return;
  const std::vector<std::size_t> run(order.begin(), order.begin() + static_cast<long>(n));
  std::optional<FusionResult::SlamFailure> followed = agreeingRun(f, run);
  if (!followed) return;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (std::size_t j : run) mean += f.fixes[j].error.head<2>();
  mean /= static_cast<double>(n);
  // From the run's last fix (inwards) to the first the result follows: eased from all to none.
  const double at_run = f.fixes[run.back()].stamp + f.time_offset;
  const double at_followed = f.fixes[order[n]].stamp + f.time_offset;
  for (Pose& p : f.poses) {
    const double u = (at_followed - p.stamp) / (at_followed - at_run);
    const double w = std::clamp(std::isfinite(u) ? u : 0.0, 0.0, 1.0);
    p.position.head<2>() += w * mean;
  }
  for (std::size_t j : run) {
    FixOutcome& o = f.fixes[j];
    o.error.head<2>() -= mean;
    o.residual = o.error.norm();
    o.weight = 1.0;
    o.verdict = FixVerdict::kUsed;
  }
  followed->begin = std::min(at_run, f.fixes[run.front()].stamp + f.time_offset);
  followed->end = std::max(at_run, f.fixes[run.front()].stamp + f.time_offset);
  f.drive_ends_followed.push_back(*followed);
  f.used += n;
  f.outliers -= n;
}

}  // namespace

void followTheDrivesEnds(FusionResult& f) {
  f.drive_ends_followed.clear();
  std::vector<std::size_t> order = takingPart(f);
  followEnd(f, order);
  std::reverse(order.begin(), order.end());
  followEnd(f, order);
}

}  // namespace flexcloud
