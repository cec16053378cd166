#include "flexcloud/sim/drive_simulator.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

namespace flexcloud::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kRouteSamples = 200000;

/// The route as a dense polyline with cumulative arc length.
class Route {
 public:
  Route(std::vector<Eigen::Vector3d> pts) : pts_(std::move(pts)), s_(pts_.size(), 0.0) {
    for (std::size_t i = 1; i < pts_.size(); ++i)
      s_[i] = s_[i - 1] + (pts_[i] - pts_[i - 1]).norm();
  }
  double length() const { return s_.back(); }

  /// True pose at arc length s: x forward along the road, z up (no roll).
  Eigen::Isometry3d poseAt(double s) const {
    s = std::clamp(s, 0.0, length());
    const auto it = std::upper_bound(s_.begin(), s_.end(), s);
    std::size_t i = static_cast<std::size_t>(std::max<std::ptrdiff_t>(1, it - s_.begin())) - 1;
    i = std::min(i, pts_.size() - 2);
    const double f = (s - s_[i]) / std::max(1e-12, s_[i + 1] - s_[i]);
    const Eigen::Vector3d p = pts_[i] + f * (pts_[i + 1] - pts_[i]);
    // Tangent over a few metres for a smooth heading.
    const std::size_t a = i >= 20 ? i - 20 : 0;
    const std::size_t b = std::min(pts_.size() - 1, i + 21);
    const Eigen::Vector3d x = (pts_[b] - pts_[a]).normalized();
    const Eigen::Vector3d y = Eigen::Vector3d::UnitZ().cross(x).normalized();
    const Eigen::Vector3d z = x.cross(y);
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() << x, y, z;
    t.translation() = p;
    return t;
  }

 private:
  std::vector<Eigen::Vector3d> pts_;
  std::vector<double> s_;
};

Route makeRoute(const SimParams& p, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> phase(0.0, 2.0 * kPi);
  const double f1 = phase(rng), f2 = phase(rng), f3 = phase(rng), f4 = phase(rng), f5 = phase(rng);
  std::vector<Eigen::Vector3d> pts(kRouteSamples);
  for (int pass = 0; pass < 3; ++pass) {  // rescale until the length matches
    const double scale = pass == 0 ? p.length / 6.0 : p.length / Route(pts).length();
    for (std::size_t i = 0; i < kRouteSamples; ++i) {
      const double u = static_cast<double>(i) / static_cast<double>(kRouteSamples - 1);
      Eigen::Vector3d q;
      if (p.loop) {
        const double th = 2.0 * kPi * u;
        const double r = 1.0 + 0.22 * std::cos(2 * th + f1) + 0.1 * std::sin(3 * th + f2) +
                         0.05 * std::cos(5 * th + f3);
        q = Eigen::Vector3d(r * std::cos(th), 0.75 * r * std::sin(th), 0.0);
        q.z() = 6.0 * std::sin(th + f4) + 1.5 * std::sin(7 * th + f5);
      } else {
        q = Eigen::Vector3d(
            u, 0.12 * std::sin(2 * kPi * 1.3 * u + f1) + 0.04 * std::sin(2 * kPi * 3.1 * u + f2),
            0.0);
        q.z() = 8.0 * std::sin(2 * kPi * 0.8 * u + f4) + 2.0 * std::sin(2 * kPi * 2.7 * u + f5);
      }
      const double z = q.z() * p.elevation;
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

/// Arc length driven at time t (s), with the optional stop halfway; `length` is the whole
/// drive (all laps).
double arcAt(double t, const SimParams& p, double length) {
  const double t_stop = 0.5 * length / p.speed;
  if (t <= t_stop) return std::min(length, p.speed * t);
  if (t <= t_stop + p.stop_duration) return 0.5 * length;
  return std::min(length, p.speed * (t - p.stop_duration));
}

Eigen::Matrix3d expSo3(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

bool inAny(const std::vector<TimeRange>& ranges, double t) {
  return std::any_of(ranges.begin(), ranges.end(),
                     [&](const TimeRange& r) { return r.contains(t); });
}

/// SLAM trajectory: true increments with scale error, heading/pitch bias and random walks.
std::vector<Eigen::Isometry3d> integrateSlam(const std::vector<Eigen::Isometry3d>& truth,
                                             const std::vector<double>& arc, const SimParams& p,
                                             std::mt19937_64& rng) {
  std::normal_distribution<double> n01(0.0, 1.0);
  const double yaw_b = p.heading_bias * kPi / 180.0 / 100.0;
  const double pitch_b = p.pitch_bias * kPi / 180.0 / 100.0;
  const std::size_t n = truth.size();
  std::vector<Eigen::Isometry3d> step(n > 0 ? n - 1 : 0);
  std::vector<double> ds(step.size());
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const Eigen::Isometry3d d = truth[k].inverse() * truth[k + 1];
    ds[k] = std::abs(arc[k + 1] - arc[k]);
    const double sq = std::sqrt(ds[k]);
    step[k] = d;
    step[k].translation() = (1.0 + p.scale_error) * d.translation() +
                            p.position_walk * sq * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
    const Eigen::Vector3d w(p.rotation_walk * sq * n01(rng),
                            pitch_b * ds[k] + p.rotation_walk * sq * n01(rng),
                            yaw_b * ds[k] + p.rotation_walk * sq * n01(rng));
    step[k].linear() = d.linear() * expSo3(w);
  }
  std::vector<Eigen::Isometry3d> slam(n, Eigen::Isometry3d::Identity());
  auto integrate = [&](std::size_t from, std::size_t to) {
    for (std::size_t k = from; k < to; ++k) slam[k + 1] = slam[k] * step[k];
  };
  integrate(0, n - 1);
  if (!p.loop || n < 2) return slam;
  // Loop closure as a pose graph would do it: the rotation error at the end is spread over the
  // increments in proportion to their length, the trajectory re-integrated, and the remaining
  // translation gap spread along the path. With close_each_lap, the SLAM also recognises every
  // revisit: the map is consistent across laps, so the first lap is closed and every later lap
  // carries the same distortion of each place (plus 2 cm of jitter); without it, only the very
  // end is closed and the laps stay apart.
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
  for (int iter = 0; iter < 5; ++iter) {
    const Eigen::AngleAxisd err(slam[end].linear().transpose() * expected.linear());
    const Eigen::Vector3d w = err.angle() * err.axis();
    for (std::size_t k = 0; k < end; ++k) {
      step[k].linear() = step[k].linear() * expSo3((ds[k] / total) * w);
    }
    integrate(0, end);
  }
  const Eigen::Vector3d gap = expected.translation() - slam[end].translation();
  for (std::size_t k = 0; k <= end; ++k) {
    slam[k].translation() += ((arc[k] - arc.front()) / total) * gap;
  }
  if (per_lap) {
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
  return slam;
}

Pose toPose(double stamp, const Eigen::Isometry3d& t) {
  Pose p;
  p.stamp = stamp;
  p.position = t.translation();
  p.orientation = Eigen::Quaterniond(t.linear()).normalized();
  return p;
}

std::uint64_t hashIndex(std::int64_t i, std::uint64_t seed) {
  std::uint64_t x = static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ull + seed;
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

double unitHash(std::int64_t i, std::uint64_t seed) {
  return static_cast<double>(hashIndex(i, seed) >> 11) * (1.0 / 9007199254740992.0);
}

void makeMap(const Route& route, const std::vector<double>& arc,
             const std::vector<Eigen::Isometry3d>& truth,
             const std::vector<Eigen::Isometry3d>& slam, const SimParams& p, std::mt19937_64& rng,
             SimMap& map) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const double length = route.length();
  const std::size_t n = p.map_points;
  map.slam.reserve(n);
  map.truth.reserve(n);
  map.intensity.reserve(n);
  map.ring.reserve(n);
  map.label.reserve(n);
  map.lateral.reserve(n);
  std::vector<std::size_t> scan(n);  // the pose that saw each point
  std::vector<double> azimuth(n);    // and its direction from that pose
  for (std::size_t i = 0; i < n; ++i) {
    double s = u01(rng) * length;
    const double kind = u01(rng);
    Eigen::Vector3d local;
    std::uint32_t label;
    const double h = -p.sensor_height + u01(rng) * 10.0;
    if (kind < 0.5) {  // ground, up to 25 m either side
      local = Eigen::Vector3d(0.0, -25.0 + 50.0 * u01(rng), -p.sensor_height);
      label = 1;
    } else if (kind < 0.85) {  // walls 8..25 m beside the road, one per 40 m stretch
      const auto seg = static_cast<std::int64_t>(s / 40.0);
      const double side = unitHash(seg, p.seed) < 0.5 ? -1.0 : 1.0;
      local = Eigen::Vector3d(0.0, side * (8.0 + 17.0 * unitHash(seg, p.seed + 1)), h);
      label = 2;
    } else {  // poles every 30 m, 4..25 m beside the road
      const auto idx = static_cast<std::int64_t>(s / 30.0);
      s = std::min(length, (static_cast<double>(idx) + 0.5) * 30.0);
      const double side = unitHash(idx, p.seed + 2) < 0.5 ? -1.0 : 1.0;
      const double a = 2.0 * kPi * u01(rng);
      local =
          Eigen::Vector3d(0.15 * std::cos(a),
                          side * (4.0 + 21.0 * unitHash(idx, p.seed + 3)) + 0.15 * std::sin(a), h);
      label = 3;
    }
    const Eigen::Vector3d truth_pt = route.poseAt(s) * local;
    // Seen from a scan up to 10 m before or after the point, on one of the laps.
    const double on_lap = std::floor(u01(rng) * p.laps) * length;
    const double s_obs = std::clamp(on_lap + s + (u01(rng) - 0.5) * 20.0, arc.front(), arc.back());
    const auto it = std::lower_bound(arc.begin(), arc.end(), s_obs);
    const std::size_t k =
        std::min<std::size_t>(static_cast<std::size_t>(it - arc.begin()), arc.size() - 1);
    scan[i] = k;
    const Eigen::Vector3d seen = truth[k].inverse() * truth_pt;
    azimuth[i] = std::atan2(seen.y(), seen.x());
    map.truth.push_back(truth_pt);
    map.slam.push_back(slam[k] * (truth[k].inverse() * truth_pt));
    map.intensity.push_back(static_cast<float>(100.0 * u01(rng)));
    map.ring.push_back(static_cast<std::uint16_t>(rng() % 32));
    map.label.push_back(label);
    map.lateral.push_back(static_cast<float>(std::abs(local.y())));
  }
  // A SLAM map is stored scan by scan, each scan as the LiDAR swept it: order the points by the
  // pose that saw them, then by azimuth.
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return scan[a] != scan[b] ? scan[a] < scan[b] : azimuth[a] < azimuth[b];
  });
  auto permute = [&](auto& v) {
    auto copy = v;
    for (std::size_t i = 0; i < n; ++i) v[i] = copy[order[i]];
  };
  permute(map.slam);
  permute(map.truth);
  permute(map.intensity);
  permute(map.ring);
  permute(map.label);
  permute(map.lateral);
}

}  // namespace

std::string validate(const SimParams& p) {
  std::ostringstream bad;
  auto req = [&](bool ok, const char* what) {
    if (!ok) bad << (bad.tellp() > 0 ? "; " : "") << what;
  };
  req(std::isfinite(p.length) && p.length >= 100.0 && p.length <= 1e6,
      "length must be in [100, 1e6] m");
  req(p.laps >= 1 && p.laps <= 100 && (p.loop || p.laps == 1),
      "laps must be 1..100, and 1 on an open route");
  req(std::isfinite(p.elevation) && p.elevation >= 0.0 && p.elevation <= 10.0,
      "elevation must be in [0, 10]");
  req(std::isfinite(p.speed) && p.speed > 0.1 && p.speed <= 100.0,
      "speed must be in (0.1, 100] m/s");
  req(std::isfinite(p.stop_duration) && p.stop_duration >= 0.0 && p.stop_duration <= 36000.0,
      "stop_duration must be in [0, 36000] s");
  req(std::isfinite(p.odom_rate) && p.odom_rate > 0.0 && p.odom_rate <= 1000.0,
      "odom_rate must be in (0, 1000] Hz");
  req(std::isfinite(p.gnss_rate) && p.gnss_rate > 0.0 && p.gnss_rate <= 1000.0,
      "gnss_rate must be in (0, 1000] Hz");
  req(p.gnss_noise_h >= 0.0 && p.gnss_noise_v >= 0.0 && p.outage_noise >= 0.0 && p.outage_std > 0.0,
      "GNSS noise and std-devs must not be negative");
  req(std::isfinite(p.clock_offset) && std::abs(p.clock_offset) <= 100.0,
      "clock_offset must be in [-100, 100] s");
  req(p.map_points <= 200000000, "map_points must be at most 2e8");
  req(p.lever_arm.allFinite() && p.lever_arm.norm() <= 10.0, "lever_arm must be within 10 m");
  const GnssErrors& e = p.gnss_errors;
  req(e.multipath_per_km >= 0.0 && e.float_per_km >= 0.0 && e.outlier_share >= 0.0 &&
          e.outlier_share <= 1.0 && e.no_covariance_share >= 0.0 && e.no_covariance_share <= 1.0 &&
          e.end_false_rtk_s >= 0.0 && e.multipath_min_s > 0.0 &&
          e.multipath_min_s <= e.multipath_max_s && e.float_min_s > 0.0 &&
          e.float_min_s <= e.float_max_s,
      "GNSS error rates must not be negative, shares at most 1, durations positive");
  req(isValidGeodetic(p.datum.lat, p.datum.lon, p.datum.alt), "datum is not a valid position");
  return bad.str();
}

SimDrive simulateDrive(const SimParams& p) {
  if (const std::string bad = validate(p); !bad.empty()) throw Error("simulator: " + bad);
  std::mt19937_64 rng(p.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const Route route = makeRoute(p, rng);
  const double lap = route.length();
  const double length = lap * p.laps;
  const double duration = length / p.speed + p.stop_duration;
  // The pose at a driven arc length: laps go round the same loop.
  auto poseAt = [&](double s) { return route.poseAt(p.laps > 1 ? std::fmod(s, lap) : s); };

  SimDrive d;
  d.params = p;
  d.datum = p.datum;
  const auto n_odom = static_cast<std::size_t>(std::floor(duration * p.odom_rate)) + 1;
  std::vector<double> arc(n_odom);
  std::vector<Eigen::Isometry3d> truth(n_odom);
  for (std::size_t k = 0; k < n_odom; ++k) {
    arc[k] = arcAt(static_cast<double>(k) / p.odom_rate, p, length);
    truth[k] = poseAt(arc[k]);
  }
  const std::vector<Eigen::Isometry3d> slam = integrateSlam(truth, arc, p, rng);
  for (std::size_t k = 0; k < n_odom; ++k) {
    const double stamp = p.start_stamp + static_cast<double>(k) / p.odom_rate;
    d.truth.push_back(toPose(stamp, truth[k]));
    d.slam.push_back(toPose(stamp, slam[k]));
  }

  const EnuFrame enu(p.datum);
  const double std_h = p.reported_std_h > 0.0 ? p.reported_std_h : p.gnss_noise_h;
  const double std_v = p.reported_std_v > 0.0 ? p.reported_std_v : p.gnss_noise_v;
  const auto n_gnss = static_cast<std::size_t>(std::floor(duration * p.gnss_rate)) + 1;
  GnssErrorModel errors(p.gnss_errors, duration, length, Eigen::Vector3d(std_h, std_h, std_v),
                        p.seed);
  for (std::size_t j = 0; j < n_gnss; ++j) {
    const double t = static_cast<double>(j) / p.gnss_rate;
    const bool outage = inAny(p.outages, t);
    const Eigen::Vector3d sigma =
        outage ? Eigen::Vector3d::Constant(p.outage_noise)
               : Eigen::Vector3d(p.gnss_noise_h, p.gnss_noise_h, p.gnss_noise_v);
    const Eigen::Vector3d noise(sigma.x() * n01(rng), sigma.y() * n01(rng), sigma.z() * n01(rng));
    const GnssErrorSample e = errors.at(t);
    const Eigen::Vector3d pos = poseAt(arcAt(t, p, length)) * p.lever_arm + noise + e.error;
    RawFix f;
    f.fix.stamp = p.start_stamp + t + p.clock_offset;
    f.has_fix = !inAny(p.no_fix, t);
    const Datum g = enu.toGeodetic(pos);
    f.fix.lat = f.has_fix ? g.lat : 0.0;
    f.fix.lon = f.has_fix ? g.lon : 0.0;
    f.fix.alt = f.has_fix ? g.alt : 0.0;
    f.fix.std_enu =
        outage ? Eigen::Vector3d::Constant(p.outage_std) : Eigen::Vector3d(std_h, std_h, std_v);
    if (!e.normal || !e.reported_std.allFinite()) f.fix.std_enu = e.reported_std;
    d.fixes.push_back(f);
  }
  makeMap(route, arc, truth, slam, p, rng, d.map);  // points of one lap, seen on any lap
  return d;
}

}  // namespace flexcloud::sim
