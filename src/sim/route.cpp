#include "route.h"

#include <algorithm>
#include <cmath>

namespace flexcloud::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kRouteSamples = 200000;
constexpr double kCurvatureBase = 10.0;  // m over which the curvature is taken

/// The shape of the route at u in [0, 1] before scaling: x, y and the height of the hills.
Eigen::Vector3d shapeAt(const SimParams& p, double u, const double f[5]) {
  Eigen::Vector3d q;
  if (p.loop && p.figure_eight) {
    // A figure eight crossing itself at u = 0 and 0.5 at right angles. The hills repeat every
    // half (the two passes of the crossing are at the same height but for the bridge).
    const double th = 2.0 * kPi * u;
    const double r = 1.0 + 0.1 * std::cos(2 * th + f[0]) + 0.05 * std::sin(4 * th + f[1]);
    q = Eigen::Vector3d(1.5 * r * std::sin(th), 0.9 * r * std::sin(th) * std::cos(th), 0.0);
    q.z() = 6.0 * std::sin(2 * th + f[3]) + 1.5 * std::sin(6 * th + f[4]);
  } else if (p.loop) {
    const double th = 2.0 * kPi * u;
    const double r = 1.0 + 0.22 * std::cos(2 * th + f[0]) + 0.1 * std::sin(3 * th + f[1]) +
                     0.05 * std::cos(5 * th + f[2]);
    q = Eigen::Vector3d(r * std::cos(th), 0.75 * r * std::sin(th), 0.0);
    q.z() = 6.0 * std::sin(th + f[3]) + 1.5 * std::sin(7 * th + f[4]);
  } else {
    q = Eigen::Vector3d(
        u, 0.12 * std::sin(2 * kPi * 1.3 * u + f[0]) + 0.04 * std::sin(2 * kPi * 3.1 * u + f[1]),
        0.0);
    q.z() = 8.0 * std::sin(2 * kPi * 0.8 * u + f[3]) + 2.0 * std::sin(2 * kPi * 2.7 * u + f[4]);
  }
  return q;
}

/// The bridge of a figure eight: the second half of the route rises to bridge_height over the
/// first at the crossing.
double bridgeAt(const SimParams& p, double u) {
  if (!(p.loop && p.figure_eight)) return 0.0;
  const double s = std::sin(kPi * u);
  return p.bridge_height * s * s;
}

}  // namespace

Route::Route(std::vector<Eigen::Vector3d> pts) : pts_(std::move(pts)), s_(pts_.size(), 0.0) {
  for (std::size_t i = 1; i < pts_.size(); ++i) s_[i] = s_[i - 1] + (pts_[i] - pts_[i - 1]).norm();
}

std::size_t Route::segmentAt(double s) const {
  const auto it = std::upper_bound(s_.begin(), s_.end(), s);
  const std::size_t i = static_cast<std::size_t>(std::max<std::ptrdiff_t>(1, it - s_.begin())) - 1;
  return std::min(i, pts_.size() - 2);
}

Eigen::Vector3d Route::tangentAt(std::size_t i) const {
  // Over a few metres, for a smooth heading.
  const std::size_t a = i >= 20 ? i - 20 : 0;
  const std::size_t b = std::min(pts_.size() - 1, i + 21);
  return (pts_[b] - pts_[a]).normalized();
}

Eigen::Isometry3d Route::poseAt(double s) const {
  s = std::clamp(s, 0.0, length());
  const std::size_t i = segmentAt(s);
  const double f = (s - s_[i]) / std::max(1e-12, s_[i + 1] - s_[i]);
  const Eigen::Vector3d p = pts_[i] + f * (pts_[i + 1] - pts_[i]);
  const Eigen::Vector3d x = tangentAt(i);
  const Eigen::Vector3d y = Eigen::Vector3d::UnitZ().cross(x).normalized();
  const Eigen::Vector3d z = x.cross(y);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() << x, y, z;
  t.translation() = p;
  return t;
}

double Route::curvatureAt(double s) const {
  const double h = 0.5 * kCurvatureBase;
  const double a = std::clamp(s - h, 0.0, length()), b = std::clamp(s + h, 0.0, length());
  if (b - a < 1e-6) return 0.0;
  const Eigen::Vector3d ta = tangentAt(segmentAt(a)), tb = tangentAt(segmentAt(b));
  const double turn =
      std::atan2(ta.x() * tb.y() - ta.y() * tb.x(), ta.x() * tb.x() + ta.y() * tb.y());
  return std::abs(turn) / (b - a);
}

Route makeRoute(const SimParams& p, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> phase(0.0, 2.0 * kPi);
  double f[5];
  for (double& x : f) x = phase(rng);
  std::vector<Eigen::Vector3d> pts(kRouteSamples);
  for (int pass = 0; pass < 3; ++pass) {  // rescale until the length matches
    const double scale = pass == 0 ? p.length / 6.0 : p.length / Route(pts).length();
    for (std::size_t i = 0; i < kRouteSamples; ++i) {
      const double u = static_cast<double>(i) / static_cast<double>(kRouteSamples - 1);
      Eigen::Vector3d q = shapeAt(p, u, f);
      const double z = q.z() * p.elevation + bridgeAt(p, u);
      if (pass == 0) {
        q *= p.loop ? p.length / 6.0 : p.length;
      } else {
        q = Eigen::Vector3d(pts[i].x() * scale, pts[i].y() * scale, 0.0);
      }
      q.z() = z;
      pts[i] = q;
    }
  }
  return Route(pts);
}

Motion::Motion(const SimParams& p, const Route& route, double length) : p_(p), length_(length) {
  if (!(p.max_speed > 0.0)) {
    duration_ = length / p.speed + p.stop_duration;
    return;
  }
  // Speed limit of each metre from the curve, then the acceleration forward and the brakes
  // backward; from and to a standstill.
  const auto n = static_cast<std::size_t>(std::ceil(length)) + 1;
  const double lap = route.length();
  std::vector<double> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double k = route.curvatureAt(std::fmod(static_cast<double>(i), lap));
    v[i] = std::min(p.max_speed, std::sqrt(p.max_lateral_accel / std::max(k, 1e-9)));
  }
  v.front() = v.back() = 0.0;
  stop_metre_ = n / 2;
  if (p.stop_duration > 0.0) v[stop_metre_] = 0.0;
  for (std::size_t i = 1; i < n; ++i) {
    v[i] = std::min(v[i], std::sqrt(v[i - 1] * v[i - 1] + 2.0 * p.max_accel));
  }
  for (std::size_t i = n - 1; i-- > 0;) {
    v[i] = std::min(v[i], std::sqrt(v[i + 1] * v[i + 1] + 2.0 * p.max_brake));
  }
  t_.assign(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) t_[i] = t_[i - 1] + 2.0 / (v[i - 1] + v[i]);
  duration_ = t_.back() + p.stop_duration;
}

double Motion::arcAt(double t) const {
  if (t_.empty()) {
    // A constant speed, with the optional stop halfway.
    const double t_stop = 0.5 * length_ / p_.speed;
    if (t <= t_stop) return std::min(length_, p_.speed * t);
    if (t <= t_stop + p_.stop_duration) return 0.5 * length_;
    return std::min(length_, p_.speed * (t - p_.stop_duration));
  }
  // The stop halfway: standing at its metre, then on as the profile goes.
  const double t_stop = t_[stop_metre_];
  if (t >= t_stop && t <= t_stop + p_.stop_duration) return static_cast<double>(stop_metre_);
  if (t > t_stop) t -= p_.stop_duration;
  const auto it = std::upper_bound(t_.begin(), t_.end(), t);
  if (it == t_.begin()) return 0.0;
  if (it == t_.end()) return std::min(length_, static_cast<double>(t_.size() - 1));
  const auto i = static_cast<std::size_t>(it - t_.begin()) - 1;
  const double f = (t - t_[i]) / (t_[i + 1] - t_[i]);
  return std::min(length_, static_cast<double>(i) + f);
}

}  // namespace flexcloud::sim
