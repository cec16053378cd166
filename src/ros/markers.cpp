#include "flexcloud/ros/markers.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

namespace flexcloud::markers {
namespace {

using visualization_msgs::Marker;

Marker base(const std::string& frame, const ros::Time& stamp, const std::string& ns, int id,
            int type) {
  Marker m;
  m.header.frame_id = frame;
  m.header.stamp = stamp;
  m.ns = ns;
  m.id = id;
  m.type = type;
  m.action = Marker::ADD;
  m.pose.orientation.w = 1.0;
  return m;
}

visualization_msgs::MarkerArray withDeleteAll(const std::string& frame) {
  visualization_msgs::MarkerArray a;
  Marker del;
  del.header.frame_id = frame;
  del.action = Marker::DELETEALL;
  a.markers.push_back(del);
  return a;
}

geometry_msgs::Point point(const Eigen::Vector3d& p) {
  geometry_msgs::Point q;
  q.x = p.x();
  q.y = p.y();
  q.z = p.z();
  return q;
}

/// Green at 0, yellow halfway, red at or beyond `red_at`.
std_msgs::ColorRGBA ramp(double value, double red_at) {
  const double f = std::clamp(value / red_at, 0.0, 1.0);
  std_msgs::ColorRGBA c;
  c.r = static_cast<float>(std::min(1.0, 2.0 * f));
  c.g = static_cast<float>(std::min(1.0, 2.0 * (1.0 - f)));
  c.b = 0.0f;
  c.a = 1.0f;
  return c;
}

}  // namespace

visualization_msgs::MarkerArray cleared(const std::string& frame) { return withDeleteAll(frame); }

visualization_msgs::MarkerArray controlPoints(const GeoreferenceResult& r, const std::string& frame,
                                              const ros::Time& stamp) {
  auto a = withDeleteAll(frame);
  Marker spheres = base(frame, stamp, "control_points", 0, Marker::SPHERE_LIST);
  spheres.scale.x = spheres.scale.y = spheres.scale.z = 2.0;
  const auto& cps = r.control_points.points;
  for (std::size_t i = 0; i < cps.size(); ++i) {
    spheres.points.push_back(point(cps[i].target));
    spheres.colors.push_back(ramp(r.residual_aligned[i], 2.0));
    Marker text = base(frame, stamp, "residuals", static_cast<int>(i), Marker::TEXT_VIEW_FACING);
    text.pose.position = point(cps[i].target + Eigen::Vector3d(0.0, 0.0, 3.0));
    text.scale.z = 1.5;
    text.color.r = text.color.g = text.color.b = text.color.a = 1.0f;
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.2f m", r.residual_aligned[i]);
    text.text = buf;
    a.markers.push_back(text);
  }
  if (!spheres.points.empty()) a.markers.push_back(spheres);
  return a;
}

visualization_msgs::MarkerArray rejectedFixes(const GeoreferenceResult& r, const std::string& frame,
                                              const ros::Time& stamp) {
  auto a = withDeleteAll(frame);
  if (!r.fusion) return a;
  Marker spheres = base(frame, stamp, "rejected_fixes", 0, Marker::SPHERE_LIST);
  spheres.scale.x = spheres.scale.y = spheres.scale.z = 1.0;
  spheres.color.r = 1.0f;
  spheres.color.a = 1.0f;
  for (const auto& o : r.fusion->fixes) {
    if (o.verdict == FixVerdict::kOutlier) spheres.points.push_back(point(o.position));
  }
  // rviz shows an empty SPHERE_LIST as an error: no fix rejected, no marker.
  if (!spheres.points.empty()) a.markers.push_back(spheres);
  // What the fusion estimated, beside the start of the drive.
  const auto& f = *r.fusion;
  Marker text = base(frame, stamp, "fusion", 0, Marker::TEXT_VIEW_FACING);
  text.pose.position = point(f.poses.front().position + Eigen::Vector3d(0.0, 0.0, 8.0));
  text.scale.z = 3.0;
  text.color.r = text.color.g = text.color.b = text.color.a = 1.0f;
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "GNSS: %zu used, %zu rejected; clock offset %.3f s; lever arm %.2f %.2f %.2f m; "
                "std-dev %.3f m (h); SLAM noise x%.1f, jitter %.3f / %.3f m (h / v)",
                f.used, f.outliers, f.time_offset, f.lever_arm.x(), f.lever_arm.y(),
                f.lever_arm.z(),
                std::isfinite(f.estimated_std_h) ? f.estimated_std_h : f.median_std_h,
                f.slam_noise_scale, f.slam_jitter_h, f.slam_jitter_v);
  text.text = buf;
  a.markers.push_back(text);
  return a;
}

visualization_msgs::MarkerArray tetrahedra(const GeoreferenceResult& r, const std::string& frame,
                                           const ros::Time& stamp) {
  auto a = withDeleteAll(frame);
  if (!r.sheet) return a;
  std::set<std::pair<int, int>> edges;
  for (const auto& t : r.sheet->tetrahedra()) {
    for (int i = 0; i < 4; ++i) {
      for (int j = i + 1; j < 4; ++j) {
        edges.emplace(std::min(t[i], t[j]), std::max(t[i], t[j]));
      }
    }
  }
  Marker lines = base(frame, stamp, "tetrahedra", 0, Marker::LINE_LIST);
  lines.scale.x = 0.3;
  lines.color.r = lines.color.g = lines.color.b = 0.6f;
  lines.color.a = 0.5f;
  const auto& targets = r.sheet->targets();
  for (const auto& [i, j] : edges) {
    lines.points.push_back(point(targets[static_cast<std::size_t>(i)]));
    lines.points.push_back(point(targets[static_cast<std::size_t>(j)]));
  }
  a.markers.push_back(lines);
  return a;
}

visualization_msgs::MarkerArray deviation(const GeoreferenceResult& r, const std::string& frame,
                                          const ros::Time& stamp, double red_at) {
  auto a = withDeleteAll(frame);
  Marker strip = base(frame, stamp, "deviation", 0, Marker::LINE_STRIP);
  strip.scale.x = 1.0;
  std_msgs::ColorRGBA grey;
  grey.r = grey.g = grey.b = 0.5f;
  grey.a = 1.0f;
  for (std::size_t i = 0; i < r.rubbersheet.size(); ++i) {
    strip.points.push_back(point(r.rubbersheet[i].position));
    const auto& g = r.gnss_at_pose[i];
    strip.colors.push_back(g ? ramp((r.rubbersheet[i].position - g->position).norm(), red_at)
                             : grey);
  }
  a.markers.push_back(strip);
  return a;
}

visualization_msgs::MarkerArray sigma(const GeoreferenceResult& r, const std::string& frame,
                                      const ros::Time& stamp, double red_at) {
  auto a = withDeleteAll(frame);
  Marker strip = base(frame, stamp, "sigma", 0, Marker::LINE_STRIP);
  strip.scale.x = 1.0;
  const double scale = red_at > 0.0 ? red_at : 0.5;
  for (std::size_t i = 0; i < r.rubbersheet.size() && i < r.sigma.h.size(); ++i) {
    strip.points.push_back(point(r.rubbersheet[i].position));
    strip.colors.push_back(ramp(r.sigma.h[i], scale));
  }
  if (!strip.points.empty()) a.markers.push_back(strip);
  return a;
}

}  // namespace flexcloud::markers
