#include "flexcloud/fusion/gnss_detail.h"

#include <algorithm>
#include <optional>

#include "flexcloud/metrics.h"

namespace flexcloud {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr double kMaxGap = 2.5;  // inliers further apart than this many median intervals: none

/// The inliers, in stamp order.
std::vector<const FixOutcome*> inliers(const FusionResult& f) {
  std::vector<const FixOutcome*> out;
  for (const auto& o : f.fixes) {
    if (o.verdict == FixVerdict::kUsed && o.error.allFinite()) out.push_back(&o);
  }
  std::sort(out.begin(), out.end(),
            [](const FixOutcome* a, const FixOutcome* b) { return a->stamp < b->stamp; });
  return out;
}

double medianInterval(const std::vector<const FixOutcome*>& in) {
  std::vector<double> d;
  for (std::size_t k = 1; k < in.size(); ++k) d.push_back(in[k]->stamp - in[k - 1]->stamp);
  return d.empty() ? 0.0 : median(std::move(d));
}

Vec3 gainOf(const FixOutcome& o) {
  const Vec3 j2 = o.slam_jitter.cwiseProduct(o.slam_jitter);
  return j2.cwiseQuotient(j2 + o.std_dev.cwiseProduct(o.std_dev)).cwiseMin(1.0).cwiseMax(0.0);
}

/// The inliers around GNSS time t and the share u of the later one: the one at t itself, or
/// two no further apart than `gap`. `k` is the search's start, kept from the previous call.
struct Bracket {
  const FixOutcome* a = nullptr;
  const FixOutcome* b = nullptr;
  double u = 0.0;
};
std::optional<Bracket> bracket(const std::vector<const FixOutcome*>& in, double t, double gap,
                               std::size_t& k) {
  while (k + 1 < in.size() && in[k]->stamp < t) ++k;  // the first inlier at or after t
  const FixOutcome* b = in[k];
  if (b->stamp == t) return Bracket{b, b, 0.0};
  if (k == 0 || b->stamp < t) return std::nullopt;
  const FixOutcome* a = in[k - 1];
  if (b->stamp - a->stamp > gap) return std::nullopt;
  return Bracket{a, b, (t - a->stamp) / (b->stamp - a->stamp)};
}

}  // namespace

void takeGnssDetail(FusionResult& f) {
  f.detail_gain.assign(f.poses.size(), 0.0);
  f.detail_poses = 0;
  f.detail_max_shift = 0.0;
  const std::vector<const FixOutcome*> in = inliers(f);
  std::vector<double> h, v;
  for (const FixOutcome* o : in) h.push_back(o->slam_jitter.x()), v.push_back(o->slam_jitter.z());
  if (in.empty()) return;
  f.slam_jitter_h = median(std::move(h));
  f.slam_jitter_v = median(std::move(v));
  const double gap = kMaxGap * medianInterval(in);
  std::size_t k = 0;
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    // A fix stamped t on the GNSS clock was taken at SLAM time t + time_offset.
    const auto br = bracket(in, f.poses[i].stamp - f.time_offset, gap, k);
    if (!br) continue;
    // The fixes' positions are smooth where the SLAM is rough: it is the GNSS's track that
    // is interpolated to the pose, never the residuals.
    const double u = br->u;
    Pose& p = f.poses[i];
    const Vec3 antenna = p.position + p.orientation * f.lever_arm;
    const Vec3 gain = (1.0 - u) * gainOf(*br->a) + u * gainOf(*br->b);
    const Vec3 fix = (1.0 - u) * br->a->position + u * br->b->position;
    const Vec3 shift = gain.cwiseProduct(fix - antenna);
    f.detail_gain[i] = std::max(gain.x(), gain.z());
    if (shift.isZero()) continue;
    p.position += shift;
    ++f.detail_poses;
    f.detail_max_shift = std::max(f.detail_max_shift, shift.norm());
  }
}

}  // namespace flexcloud
