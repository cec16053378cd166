#include "flexcloud/sheet/control_points.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "flexcloud/input/trajectory.h"

namespace flexcloud {

bool isUsableGnss(const std::optional<GnssPoint>& gnss, double pose_stamp,
                  const ControlPointOptions& options) {
  if (!gnss) return false;
  if (!(gnss->stdDevH() <= options.stddev_threshold)) return false;
  return std::none_of(options.excluded_ranges.begin(), options.excluded_ranges.end(),
                      [&](const TimeRange& r) { return r.contains(pose_stamp); });
}

ControlPointSelection selectControlPoints(const Trajectory& poses,
                                          const std::vector<std::optional<GnssPoint>>& gnss,
                                          const ControlPointOptions& options) {
  ControlPointSelection out;
  out.requested = static_cast<std::size_t>(std::max(options.count, 0));
  const std::vector<double> s = arcLength(positionsOf(poses));
  std::vector<std::size_t> matched;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (gnss[i]) matched.push_back(i);
  }
  if (matched.empty() || out.requested == 0) {
    out.skipped = out.requested;
    return out;
  }
  const double s_begin = s[matched.front()];
  const double s_end = s[matched.back()];
  const std::size_t n = out.requested;
  const double spacing = n > 1 ? (s_end - s_begin) / static_cast<double>(n - 1) : 0.0;

  std::vector<std::size_t> chosen;
  chosen.reserve(std::min(n, matched.size()));
  std::vector<bool> taken(poses.size(), false);
  for (std::size_t k = 0; k < n; ++k) {
    const double target = s_begin + spacing * static_cast<double>(k);
    const double lo = target - 0.5 * spacing;
    const double hi = target + 0.5 * spacing;
    // matched is sorted by pose index and so by arc length: search outward from the target.
    const auto it = std::lower_bound(matched.begin(), matched.end(), target,
                                     [&](std::size_t i, double v) { return s[i] < v; });
    auto right = it;
    auto left = it;
    std::optional<std::size_t> best;
    bool first = true;
    while (true) {
      const bool can_right = right != matched.end() && s[*right] <= hi;
      const bool can_left = left != matched.begin() && s[*(left - 1)] >= lo;
      if (!can_right && !can_left) break;
      std::size_t cand;
      if (can_right && (!can_left || s[*right] - target <= target - s[*(left - 1)])) {
        cand = *right++;
      } else {
        cand = *--left;
      }
      if (isUsableGnss(gnss[cand], poses[cand].stamp, options)) {
        best = cand;
        break;
      }
      first = false;
    }
    if (!best) {
      ++out.skipped;
      continue;
    }
    if (!first) ++out.replaced;
    if (taken[*best]) {
      ++out.merged;
      continue;
    }
    taken[*best] = true;
    chosen.push_back(*best);
  }
  addControlPoints(out, chosen, poses, gnss);
  return out;
}

std::vector<std::size_t> pickRefinements(const ControlPointSelection& selection,
                                         const std::vector<double>& deviation,
                                         const std::vector<double>& arc, double min_separation,
                                         std::size_t max_new, double min_deviation) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::vector<std::pair<double, std::size_t>> worst;  // per stretch: (deviation, pose)
  std::size_t begin = 0;
  double s_begin = -kInf;
  auto scan = [&](std::size_t from, std::size_t to, double s_from, double s_to) {
    double best = min_deviation;
    std::size_t arg = to;
    for (std::size_t i = from; i < to; ++i) {
      if (arc[i] - s_from < min_separation || s_to - arc[i] < min_separation) continue;
      if (deviation[i] > best) {
        best = deviation[i];
        arg = i;
      }
    }
    if (arg != to) worst.emplace_back(best, arg);
  };
  for (const auto& cp : selection.points) {
    scan(begin, cp.pose_index, s_begin, arc[cp.pose_index]);
    begin = cp.pose_index + 1;
    s_begin = arc[cp.pose_index];
  }
  scan(begin, deviation.size(), s_begin, kInf);
  const std::size_t n = std::min(max_new, worst.size());
  std::partial_sort(worst.begin(), worst.begin() + static_cast<std::ptrdiff_t>(n), worst.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::size_t> out;
  out.reserve(n);
  for (std::size_t k = 0; k < n; ++k) out.push_back(worst[k].second);
  return out;
}

void addControlPoints(ControlPointSelection& selection, const std::vector<std::size_t>& poses,
                      const Trajectory& trajectory,
                      const std::vector<std::optional<GnssPoint>>& gnss) {
  for (std::size_t i : poses) {
    ControlPoint cp;
    cp.pose_index = i;
    cp.stamp = trajectory[i].stamp;
    cp.source = trajectory[i].position;
    cp.target = gnss[i]->position;
    cp.std_dev = gnss[i]->stdDev3d();
    selection.points.push_back(cp);
  }
  std::sort(
      selection.points.begin(), selection.points.end(),
      [](const ControlPoint& a, const ControlPoint& b) { return a.pose_index < b.pose_index; });
}

}  // namespace flexcloud
