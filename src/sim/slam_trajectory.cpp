#include "slam_trajectory.h"

#include <algorithm>
#include <cmath>

namespace flexcloud::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegPer100m = kPi / 180.0 / 100.0;  // rad per m
constexpr int kRotationRounds = 5;  // rounds of spreading a closure's rotation error

using Steps = std::vector<Eigen::Isometry3d>;

Eigen::Matrix3d expSo3(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

/// Per stretch of the route (SlamErrors): where it begins (m of path), the factor of the
/// rotation walk and the change of the heading drift rate (rad per m).
struct Stretch {
  double begin = 0.0, walk = 1.0, heading_rate = 0.0;
};

std::vector<Stretch> drawStretches(const SlamErrors& e, double length, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<Stretch> out;
  for (double s = 0.0; s < length;) {
    Stretch st;
    st.begin = s;
    if (u(rng) < e.degenerate_share) st.walk = std::pow(e.walk_factor_max, u(rng));
    st.heading_rate = e.heading_bias_change * kDegPer100m * n01(rng);
    out.push_back(st);
    s += e.stretch_min_m + (e.stretch_max_m - e.stretch_min_m) * u(rng);
  }
  return out;
}

bool hasStretches(const SlamErrors& e) {
  return e.degenerate_share > 0.0 || e.heading_bias_change > 0.0;
}

/// The steady drift of SimParams: true increments with scale error, heading and pitch rates
/// and random walks. ds: the path of each step.
Steps steadySteps(const std::vector<Eigen::Isometry3d>& truth, const std::vector<double>& ds,
                  const SimParams& p, std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  const double yaw_b = p.heading_bias * kDegPer100m;
  const double pitch_b = p.pitch_bias * kDegPer100m;
  Steps step(ds.size());
  for (std::size_t k = 0; k < ds.size(); ++k) {
    const Eigen::Isometry3d d = truth[k].inverse() * truth[k + 1];
    const double sq = std::sqrt(ds[k]);
    step[k] = d;
    step[k].translation() = (1.0 + p.scale_error) * d.translation() +
                            p.position_walk * sq * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    const Eigen::Vector3d w(p.rotation_walk * sq * n01(rng),
                            pitch_b * ds[k] + p.rotation_walk * sq * n01(rng),
                            yaw_b * ds[k] + p.rotation_walk * sq * n01(rng));
    step[k].linear() = d.linear() * expSo3(w);
  }
  return step;
}

/// Adds the stretches' stronger rotation walk and changed heading rates to the steps.
void addStretchErrors(Steps& step, const std::vector<double>& arc, const std::vector<double>& ds,
                      const SimParams& p, std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  const std::vector<Stretch> st = drawStretches(p.slam_errors, arc.back() - arc.front(), rng);
  std::size_t i = 0;
  for (std::size_t k = 0; k < step.size(); ++k) {
    while (i + 1 < st.size() && st[i + 1].begin <= arc[k] - arc.front()) ++i;
    // The walk's variance grows to walk^2 times the steady one.
    const double extra = p.rotation_walk * std::sqrt(st[i].walk * st[i].walk - 1.0);
    const double sq = std::sqrt(ds[k]);
    const Eigen::Vector3d w(extra * sq * n01(rng), extra * sq * n01(rng),
                            st[i].heading_rate * ds[k] + extra * sq * n01(rng));
    step[k].linear() = step[k].linear() * expSo3(w);
  }
}

/// Height error added per step (m) by a grade error that wanders along the path.
std::vector<double> heightDrift(const std::vector<double>& ds, const SlamErrors& e,
                                std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<double> dz(ds.size(), 0.0);
  double grade = e.grade_error;
  for (std::size_t k = 0; k < ds.size(); ++k) {
    dz[k] = grade * ds[k];
    grade += e.grade_walk * std::sqrt(ds[k] / 1000.0) * n01(rng);
  }
  return dz;
}

/// Chains the steps from pose `from` up to pose `to`; dz (may be empty) is added to the height
/// of the SLAM frame at every step.
void integrate(std::vector<Eigen::Isometry3d>& slam, const Steps& step,
               const std::vector<double>& dz, std::size_t from, std::size_t to) {
  for (std::size_t k = from; k < to; ++k) {
    slam[k + 1] = slam[k] * step[k];
    if (!dz.empty()) slam[k + 1].translation().z() += dz[k];
  }
}

/// Spreads the rotation error at pose `end` against `expected` (the pose the SLAM would give
/// it without drift, in its frame) over the steps since `begin`, in proportion to their path,
/// and chains everything after `begin` again.
void spreadRotation(std::vector<Eigen::Isometry3d>& slam, Steps& step,
                    const std::vector<double>& dz, const std::vector<double>& arc,
                    const std::vector<double>& ds, const Eigen::Isometry3d& expected,
                    std::size_t begin, std::size_t end) {
  const double total = std::max(1e-9, arc[end] - arc[begin]);
  for (int iter = 0; iter < kRotationRounds; ++iter) {
    const Eigen::AngleAxisd err(slam[end].linear().transpose() * expected.linear());
    const Eigen::Vector3d w = err.angle() * err.axis();
    for (std::size_t k = begin; k < end; ++k) {
      step[k].linear() = step[k].linear() * expSo3((ds[k] / total) * w);
    }
    integrate(slam, step, dz, begin, slam.size() - 1);
  }
}

/// Where the pose graph closes loops (SlamErrors::closures): at the end of the first lap, and on
/// every later lap each time the place has been recognised again, every closure_min_m ..
/// closure_max_m of path.
std::vector<std::size_t> closurePoses(const std::vector<double>& arc, const SimParams& p,
                                      std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const SlamErrors& e = p.slam_errors;
  const double lap = (arc.back() - arc.front()) / p.laps;
  std::vector<std::size_t> out;
  double next = arc.front() + lap;
  while (next < arc.back()) {
    const auto at = std::lower_bound(arc.begin(), arc.end(), next - 1e-6);
    out.push_back(static_cast<std::size_t>(at - arc.begin()));
    next += e.closure_min_m + (e.closure_max_m - e.closure_min_m) * u(rng);
  }
  return out;
}

/// The pose the first pass gives the place of pose k (a later lap): the first lap's pose of
/// that place, moved by the true motion between the two.
Eigen::Isometry3d firstPassPose(const std::vector<Eigen::Isometry3d>& slam,
                                const std::vector<Eigen::Isometry3d>& truth,
                                const std::vector<double>& arc, double lap, std::size_t k) {
  const double on_first = arc.front() + std::fmod(arc[k] - arc.front(), lap);
  const auto j =
      static_cast<std::size_t>(std::lower_bound(arc.begin(), arc.end(), on_first) - arc.begin());
  return slam[j] * truth[j].inverse() * truth[k];
}

/// The pose graph's loop closures (SlamErrors::closures). At each closure the pose must agree
/// with the first pass over its place (with the start, at the end of the first lap): the
/// rotation error is spread over the steps since the last closure, and so is the translation
/// error but for a snap that shows at the closure; everything after moves with the closed pose.
/// Between closures a later lap drifts away from the first: the map holds its places twice,
/// up to the drift of a few hundred metres apart.
void closeLaps(std::vector<Eigen::Isometry3d>& slam, Steps& step, const std::vector<double>& dz,
               const std::vector<Eigen::Isometry3d>& truth, const std::vector<double>& arc,
               const std::vector<double>& ds, const SimParams& p, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const SlamErrors& e = p.slam_errors;
  const double lap = (arc.back() - arc.front()) / p.laps;
  std::size_t begin = 0;
  for (std::size_t end : closurePoses(arc, p, rng)) {
    if (end <= begin) continue;
    const Eigen::Isometry3d expected = firstPassPose(slam, truth, arc, lap, end);
    spreadRotation(slam, step, dz, arc, ds, expected, begin, end);
    const Eigen::Vector3d gap = expected.translation() - slam[end].translation();
    Eigen::Vector3d dir(gap.x(), gap.y(), 0.0);
    if (dir.norm() < 1e-3) dir = Eigen::Vector3d(std::cos(2 * kPi * u(rng)), 0.0, 0.0);
    const double size = e.snap_min_m + (e.snap_max_m - e.snap_min_m) * u(rng);
    const Eigen::Vector3d snap = std::min(size, gap.norm()) * dir.normalized();
    const double total = std::max(1e-9, arc[end] - arc[begin]);
    for (std::size_t k = begin + 1; k < end; ++k) {
      slam[k].translation() += ((arc[k] - arc[begin]) / total) * (gap - snap);
    }
    for (std::size_t k = end; k < slam.size(); ++k) slam[k].translation() += gap;
    begin = end;
  }
}

/// Loop closure at the very end as a pose graph would do it: the rotation error spread over
/// the increments in proportion to their length, the trajectory re-integrated, and the
/// remaining translation gap spread along the path. With close_each_lap, the SLAM also
/// recognises every revisit: the map is consistent across laps, so the first lap is closed and
/// every later lap carries the same distortion of each place (plus 2 cm of jitter); without
/// it, only the very end is closed and the laps stay apart.
void closeSmoothly(std::vector<Eigen::Isometry3d>& slam, Steps& step, const std::vector<double>& dz,
                   const std::vector<Eigen::Isometry3d>& truth, const std::vector<double>& arc,
                   const std::vector<double>& ds, const SimParams& p, std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  const std::size_t n = slam.size();
  const double lap = (arc.back() - arc.front()) / p.laps;
  const bool per_lap = p.close_each_lap && p.laps > 1;
  std::size_t end = n - 1;
  if (per_lap) {
    end = static_cast<std::size_t>(
        std::lower_bound(arc.begin(), arc.end(), arc.front() + lap - 1e-6) - arc.begin());
    end = std::min(end, n - 1);
  }
  const Eigen::Isometry3d expected = truth.front().inverse() * truth[end];
  const double total = std::max(1e-9, arc[end] - arc.front());
  for (int iter = 0; iter < kRotationRounds; ++iter) {
    const Eigen::AngleAxisd err(slam[end].linear().transpose() * expected.linear());
    const Eigen::Vector3d w = err.angle() * err.axis();
    for (std::size_t k = 0; k < end; ++k) {
      step[k].linear() = step[k].linear() * expSo3((ds[k] / total) * w);
    }
    integrate(slam, step, dz, 0, end);
  }
  const Eigen::Vector3d gap = expected.translation() - slam[end].translation();
  for (std::size_t k = 0; k <= end; ++k) {
    slam[k].translation() += ((arc[k] - arc.front()) / total) * gap;
  }
  if (!per_lap) return;
  for (std::size_t k = end + 1; k < n; ++k) {
    const double on_first = arc.front() + std::fmod(arc[k] - arc.front(), lap);
    const auto j = std::min<std::size_t>(
        static_cast<std::size_t>(
            std::lower_bound(arc.begin(), arc.begin() + static_cast<std::ptrdiff_t>(end) + 1,
                             on_first) -
            arc.begin()),
        end);
    slam[k] = slam[j] * truth[j].inverse() * truth[k];  // the same distortion of the place
    slam[k].translation() += 0.02 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
  }
}

/// Every pose's position off by white noise of its own (SlamErrors::pose_jitter).
void addPoseJitter(std::vector<Eigen::Isometry3d>& slam, const SimParams& p) {
  if (!(p.slam_errors.pose_jitter > 0.0)) return;
  std::mt19937_64 rng(p.seed ^ 0x7a1e5c3dull);
  std::normal_distribution<double> n(0.0, p.slam_errors.pose_jitter);
  for (auto& pose : slam) pose.translation() += Eigen::Vector3d(n(rng), n(rng), n(rng));
}

/// The SLAM's poses before their jitter (integrateSlam).
std::vector<Eigen::Isometry3d> integrateSmoothSlam(const std::vector<Eigen::Isometry3d>& truth,
                                                   const std::vector<double>& arc,
                                                   const SimParams& p, std::mt19937_64& rng) {
  const std::size_t n = truth.size();
  std::vector<Eigen::Isometry3d> slam(n, Eigen::Isometry3d::Identity());
  if (n < 2) return slam;
  std::vector<double> ds(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) ds[k] = std::abs(arc[k + 1] - arc[k]);
  Steps step = steadySteps(truth, ds, p, rng);
  // The failures of SlamErrors draw from a generator of their own: a drive without them is the
  // same drive as before they existed.
  std::mt19937_64 failures(p.seed ^ 0x51a3e7707ull);
  const SlamErrors& e = p.slam_errors;
  if (hasStretches(e)) addStretchErrors(step, arc, ds, p, failures);
  std::vector<double> dz;
  if (e.grade_error != 0.0 || e.grade_walk > 0.0) dz = heightDrift(ds, e, failures);
  integrate(slam, step, dz, 0, n - 1);
  if (!p.loop || !p.close_loop) return slam;
  if (e.closures && p.laps > 1) {
    closeLaps(slam, step, dz, truth, arc, ds, p, failures);
  } else {
    closeSmoothly(slam, step, dz, truth, arc, ds, p, rng);
  }
  return slam;
}

}  // namespace

std::vector<Eigen::Isometry3d> integrateSlam(const std::vector<Eigen::Isometry3d>& truth,
                                             const std::vector<double>& arc, const SimParams& p,
                                             std::mt19937_64& rng) {
  std::vector<Eigen::Isometry3d> slam = integrateSmoothSlam(truth, arc, p, rng);
  addPoseJitter(slam, p);
  return slam;
}

std::vector<std::size_t> keyframeIndices(const std::vector<double>& arc, const SlamErrors& e,
                                         std::uint64_t seed) {
  std::vector<std::size_t> out;
  if (!(e.keyframe_max_m > 0.0)) {
    for (std::size_t i = 0; i < arc.size(); ++i) out.push_back(i);
    return out;
  }
  std::mt19937_64 rng(seed ^ 0x6b3f0a11ull);
  std::uniform_real_distribution<double> u(e.keyframe_min_m, e.keyframe_max_m);
  double next = u(rng);
  out.push_back(0);
  for (std::size_t i = 1; i + 1 < arc.size(); ++i) {
    if (arc[i] - arc[out.back()] < next) continue;
    out.push_back(i);
    next = u(rng);
  }
  if (arc.size() > 1) out.push_back(arc.size() - 1);
  return out;
}

}  // namespace flexcloud::sim
