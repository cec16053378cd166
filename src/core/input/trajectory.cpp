#include "flexcloud/input/trajectory.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace flexcloud {

Trajectory preparePoses(const Trajectory& poses, PoseCounts& counts) {
  counts = PoseCounts{};
  counts.received = poses.size();
  Trajectory valid;
  valid.reserve(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    Pose p = poses[i];
    const double qn = p.orientation.coeffs().norm();
    if (!std::isfinite(p.stamp) || !p.position.allFinite() || !std::isfinite(qn) || qn < 1e-6 ||
        p.position.cwiseAbs().maxCoeff() > 1e8) {
      ++counts.invalid;
      continue;
    }
    if (std::abs(qn - 1.0) > 1e-6) ++counts.normalised;
    p.orientation.coeffs() /= qn;
    if (!valid.empty() && p.stamp < valid.back().stamp) ++counts.reordered;
    valid.push_back(p);
  }
  std::stable_sort(valid.begin(), valid.end(),
                   [](const Pose& a, const Pose& b) { return a.stamp < b.stamp; });
  Trajectory out;
  out.reserve(valid.size());
  for (const auto& p : valid) {
    if (!out.empty() && p.stamp == out.back().stamp) {
      ++counts.duplicate;
      continue;
    }
    out.push_back(p);
  }
  return out;
}

std::string droppedInWords(const PoseCounts& c) {
  std::string out;
  if (c.invalid > 0) {
    out = std::to_string(c.invalid) +
          " invalid (a stamp, position or quaternion that is not a finite number, a zero "
          "quaternion, a coordinate beyond 1e8 m)";
  }
  if (c.duplicate > 0) {
    out += (out.empty() ? "" : ", ") + std::to_string(c.duplicate) +
           " with the stamp of an earlier pose";
  }
  return out;
}

BodyAxes bodyAxes(const Trajectory& poses) {
  constexpr double kLeastStep = 0.05;  // m between poses that show the motion's direction
  Eigen::Vector3d ahead = Eigen::Vector3d::Zero(), up = Eigen::Vector3d::Zero();
  for (std::size_t i = 1; i < poses.size(); ++i) {
    const Eigen::Vector3d step = poses[i].position - poses[i - 1].position;
    if (!(step.norm() >= kLeastStep)) continue;
    const Eigen::Matrix3d r = poses[i].orientation.normalized().toRotationMatrix();
    ahead += r.transpose() * step.normalized();
    up += r.transpose() * Eigen::Vector3d::UnitZ();
  }
  BodyAxes a;
  if (!(ahead.norm() > 0.0)) return a;
  a.ahead = ahead.normalized();
  const Eigen::Vector3d level = up - up.dot(a.ahead) * a.ahead;
  a.up = level.norm() > 0.0 ? level.normalized() : a.ahead.unitOrthogonal();
  a.left = a.up.cross(a.ahead).normalized();
  return a;
}

std::vector<double> arcLength(const std::vector<Eigen::Vector3d>& positions) {
  std::vector<double> s(positions.size(), 0.0);
  for (std::size_t i = 1; i < positions.size(); ++i) {
    s[i] = s[i - 1] + (positions[i] - positions[i - 1]).norm();
  }
  return s;
}

std::vector<Eigen::Vector3d> positionsOf(const Trajectory& poses) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(poses.size());
  for (const auto& p : poses) out.push_back(p.position);
  return out;
}

Eigen::Isometry3d isometryOf(const Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = p.orientation.normalized().toRotationMatrix();
  t.translation() = p.position;
  return t;
}

std::optional<Pose> poseAt(const Trajectory& poses, double t) {
  const auto it = std::lower_bound(poses.begin(), poses.end(), t,
                                   [](const Pose& p, double s) { return p.stamp < s; });
  if (it == poses.end()) return std::nullopt;
  if (it->stamp == t) return *it;
  if (it == poses.begin()) return std::nullopt;
  const Pose& a = *(it - 1);
  const double f = (t - a.stamp) / (it->stamp - a.stamp);
  Pose out;
  out.stamp = t;
  out.position = a.position + f * (it->position - a.position);
  out.orientation = a.orientation.slerp(f, it->orientation);
  return out;
}

std::vector<double> deviationsAtFixes(const Trajectory& track, const std::vector<GnssPoint>& fixes,
                                      double offset, const Eigen::Vector3d& lever_arm) {
  std::vector<double> out;
  out.reserve(fixes.size());
  for (const auto& g : fixes) {
    const std::optional<Pose> p = poseAt(track, g.stamp + offset);
    out.push_back(p ? (p->position + p->orientation * lever_arm - g.position).norm()
                    : std::numeric_limits<double>::quiet_NaN());
  }
  return out;
}

}  // namespace flexcloud
