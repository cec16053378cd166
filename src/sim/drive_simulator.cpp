#include "flexcloud/sim/drive_simulator.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "route.h"
#include "slam_trajectory.h"

namespace flexcloud::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

bool inAny(const std::vector<TimeRange>& ranges, double t) {
  return std::any_of(ranges.begin(), ranges.end(),
                     [&](const TimeRange& r) { return r.contains(t); });
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
  map.time.reserve(n);
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
    map.time.push_back(p.start_stamp + static_cast<double>(k) / p.odom_rate);
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
  permute(map.time);
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
  req(std::isfinite(p.gnss_late_s) && std::isfinite(p.gnss_early_s) && p.gnss_late_s >= 0.0 &&
          p.gnss_early_s >= 0.0,
      "gnss_late_s and gnss_early_s must be finite and not negative");
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
  req(std::isfinite(p.max_speed) && p.max_speed >= 0.0 && p.max_speed <= 150.0 &&
          p.max_lateral_accel > 0.0 && p.max_accel > 0.0 && p.max_brake > 0.0,
      "max_speed must be in [0, 150] m/s, the accelerations positive");
  req(std::isfinite(p.bridge_height) && std::abs(p.bridge_height) <= 100.0,
      "bridge_height must be within 100 m");
  const SlamErrors& s = p.slam_errors;
  req(s.degenerate_share >= 0.0 && s.degenerate_share <= 1.0 && s.walk_factor_max >= 1.0 &&
          s.heading_bias_change >= 0.0 && s.stretch_min_m > 0.0 &&
          s.stretch_min_m <= s.stretch_max_m && s.grade_walk >= 0.0 &&
          std::abs(s.grade_error) <= 0.1 && s.snap_min_m >= 0.0 && s.snap_min_m <= s.snap_max_m &&
          s.closure_min_m > 0.0 && s.closure_min_m <= s.closure_max_m && s.keyframe_min_m >= 0.0 &&
          s.keyframe_min_m <= s.keyframe_max_m,
      "SLAM errors: shares in [0, 1], factors at least 1, ranges ordered, grade within 0.1");
  req(s.pose_jitter >= 0.0 && s.pose_jitter <= 1.0, "SLAM pose jitter must be in [0, 1] m");
  req(e.correlated_m >= 0.0 && e.correlated_tau_s > 0.0,
      "GNSS correlated error must not be negative, its time constant positive");
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
  const Motion motion(p, route, length);
  const double duration = motion.duration();
  // The pose at a driven arc length: laps go round the same loop.
  auto poseAt = [&](double s) { return route.poseAt(p.laps > 1 ? std::fmod(s, lap) : s); };

  SimDrive d;
  d.params = p;
  d.datum = p.datum;
  const auto n_odom = static_cast<std::size_t>(std::floor(duration * p.odom_rate)) + 1;
  std::vector<double> arc(n_odom);
  std::vector<Eigen::Isometry3d> truth(n_odom);
  for (std::size_t k = 0; k < n_odom; ++k) {
    arc[k] = motion.arcAt(static_cast<double>(k) / p.odom_rate);
    truth[k] = poseAt(arc[k]);
  }
  const std::vector<Eigen::Isometry3d> slam = integrateSlam(truth, arc, p, rng);
  for (std::size_t k : keyframeIndices(arc, p.slam_errors, p.seed)) {
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
    const Eigen::Vector3d pos = poseAt(motion.arcAt(t)) * p.lever_arm + noise + e.error;
    RawFix f;
    f.fix.stamp = p.start_stamp + t - p.clock_offset;
    f.has_fix = !inAny(p.no_fix, t) && t >= p.gnss_late_s && t <= duration - p.gnss_early_s;
    const Datum g = enu.toGeodetic(pos);
    f.fix.lat = f.has_fix ? g.lat : 0.0;
    f.fix.lon = f.has_fix ? g.lon : 0.0;
    f.fix.alt = f.has_fix ? g.alt : 0.0;
    f.fix.std_enu =
        outage ? Eigen::Vector3d::Constant(p.outage_std) : Eigen::Vector3d(std_h, std_h, std_v);
    if (!e.normal || !e.reported_std.allFinite()) f.fix.std_enu = e.reported_std;
    d.fixes.push_back(f);
  }
  // Points of one lap, seen on any lap from every pose (a keyframe SLAM maps every scan too).
  makeMap(route, arc, truth, slam, p, rng, d.map);
  return d;
}

DriveInput driveInput(const SimDrive& d) {
  DriveInput in;
  in.fixes = d.fixes;
  in.poses = d.slam;
  return in;
}

Params atSimDatum(const SimDrive& d, Params p) {
  p.datum_lat = d.datum.lat;
  p.datum_lon = d.datum.lon;
  p.datum_alt = d.datum.alt;
  return p;
}

}  // namespace flexcloud::sim
