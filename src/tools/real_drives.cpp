#include "real_drives.h"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/io/text_io.h"
#include "flexcloud/metrics.h"

namespace flexcloud::study {

DriveInput loadRealDrive(const std::string& dir) {
  for (const char* name : {"slam_poses_tum.txt", "gnss_local_at_poses.txt"}) {
    if (!std::filesystem::exists(dir + "/" + name)) {
      throw Error("real drive: " + dir + "/" + name + " does not exist");
    }
  }
  DriveInput in;
  in.poses = readTumFile(dir + "/slam_poses_tum.txt");
  in.local_gnss = readLocalGnssFile(dir + "/gnss_local_at_poses.txt");
  return in;
}

LeaveOutSplit holdOut(const DriveInput& drive, std::size_t every) {
  LeaveOutSplit s;
  s.run = drive;
  s.run.local_gnss.clear();
  for (std::size_t i = 0; i < drive.local_gnss.size(); ++i) {
    (i % every == every / 2 ? s.held_out : s.run.local_gnss).push_back(drive.local_gnss[i]);
  }
  return s;
}

namespace {

/// Speed (m/s, horizontal) at row i of the GNSS, from its neighbours.
double speedAt(const std::vector<GnssPoint>& g, std::size_t i) {
  return (g[i + 1].position - g[i - 1].position).head<2>().norm() /
         (g[i + 1].stamp - g[i - 1].stamp);
}

}  // namespace

std::vector<LagSample> lagSamples(const DriveInput& drive) {
  constexpr int kHalf = 10;
  const std::vector<GnssPoint>& g = drive.local_gnss;
  std::vector<LagSample> out;
  if (g.size() != drive.poses.size()) return out;  // row i of one belongs to row i of the other
  // speedAt(j) reads j - 1 and j + 1: the windows keep one fix from either end.
  for (std::size_t i = kHalf + 1; i + kHalf + 1 < g.size(); ++i) {
    Eigen::Matrix3Xd src(3, 2 * kHalf + 1), dst(3, 2 * kHalf + 1);
    double mean_speed = 0.0;
    for (int k = -kHalf; k <= kHalf; ++k) {
      src.col(k + kHalf) = drive.poses[i + k].position;
      dst.col(k + kHalf) = g[i + k].position;
      mean_speed += speedAt(g, i + k) / (2 * kHalf + 1);
    }
    const Eigen::Matrix4d T = Eigen::umeyama(src, dst, false);
    const Eigen::Vector3d fitted =
        T.topLeftCorner<3, 3>() * drive.poses[i].position + T.topRightCorner<3, 1>();
    const Eigen::Vector2d dir = (g[i + 1].position - g[i - 1].position).head<2>().normalized();
    LagSample s;
    s.speed = speedAt(g, i);
    s.speed_change = s.speed - mean_speed;
    s.along = dir.dot((g[i].position - fitted).head<2>());
    out.push_back(s);
  }
  return out;
}

double lagOf(const std::vector<LagSample>& samples) {
  // Least squares through the origin, then again without the samples beyond 3 robust sigmas
  // of its residual, twice (a2rl's disputed stretch and stops alone moved it by 6 ms).
  auto fit = [&](double keep, double lag) {
    double xy = 0.0, xx = 0.0;
    for (const auto& s : samples) {
      if (std::abs(s.along - lag * s.speed_change) > keep) continue;
      xy += s.speed_change * s.along;
      xx += s.speed_change * s.speed_change;
    }
    return xx > 0.0 ? xy / xx : 0.0;
  };
  double lag = fit(std::numeric_limits<double>::infinity(), 0.0);
  for (int round = 0; round < 2; ++round) {
    std::vector<double> r;
    for (const auto& s : samples) r.push_back(std::abs(s.along - lag * s.speed_change));
    if (r.empty()) break;
    lag = fit(3.0 * 1.4826 * median(r), lag);
  }
  return lag;
}

ErrorStats heldOutError(const GeoreferenceResult& r, const Params& p,
                        const std::vector<GnssPoint>& held_out, double offset) {
  const Eigen::Vector3d lever(p.lever_arm_x, p.lever_arm_y, p.lever_arm_z);
  std::vector<double> d;
  for (double x : deviationsAtFixes(r.rubbersheet, held_out, offset, lever)) {
    if (std::isfinite(x)) d.push_back(x);
  }
  return errorStats(d);
}

namespace {

void printRow(const std::string& drive, const std::string& method, const ErrorStats& e,
              const GeoreferenceResult& r) {
  std::printf("| %s | %s | %.3f | %.3f | %.3f | %zu | %s |\n", drive.c_str(), method.c_str(), e.mae,
              e.max, e.rmse, e.count, notesOf(r).c_str());
  std::fflush(stdout);
}

}  // namespace

std::string notesOf(const GeoreferenceResult& r) {
  std::string out = toString(r.method);
  char buf[200];
  if (r.speed_clock && r.speed_clock->observable) {
    std::snprintf(buf, sizeof(buf), ", clock %.4f +- %.4f s from the speeds%s",
                  r.speed_clock->offset, r.speed_clock->sigma,
                  std::isfinite(r.clock_offset_sigma) ? "" : " (within its noise: not applied)");
    out += buf;
  }
  if (!r.fusion) return out;
  const FusionResult& f = *r.fusion;
  std::snprintf(buf, sizeof(buf),
                ", dt %.4f s%s, %zu rejected, SLAM noise x%.2f, fusion %.2f s, %zu precise fixes "
                "(q %.1e m^2/m, excess %.3f m, %zu taken back, %zu jumps)",
                f.time_offset, f.time_offset_estimated ? "" : " (fixed)", f.outliers,
                f.slam_noise_scale, f.seconds, f.follow.fixes, f.follow.q_h, f.follow.excess,
                f.follow.taken_back, f.follow.jumps);
  out += buf;
  if (std::isfinite(f.estimated_std_h)) {
    std::snprintf(buf, sizeof(buf), ", std-dev %.3f m estimated", f.estimated_std_h);
    out += buf;
  }
  return out;
}

void printRealDriveRows(const std::string& dir, std::size_t every, int control_points,
                        const std::vector<std::pair<std::string, std::string>>& sets) {
  const DriveInput drive = loadRealDrive(dir);
  if (drive.poses.size() != drive.local_gnss.size()) {
    throw Error("real drive: " + dir + ": " + std::to_string(drive.poses.size()) + " poses but " +
                std::to_string(drive.local_gnss.size()) +
                " GNSS rows; row i of one file must belong to row i of the other");
  }
  const double lag = lagOf(lagSamples(drive));
  const LeaveOutSplit split = holdOut(drive, every);
  char label[64];
  std::snprintf(label, sizeof(label), "%s (GNSS %+.3f s)",
                std::filesystem::path(dir).filename().string().c_str(), lag);
  const std::string name = label;
  auto make = [&](bool fusion, double refine) {
    Params p;
    p.fusion = fusion;
    p.control_points = control_points;
    p.refine_fraction = refine;
    if (!fusion) p.default_std_dev = 0.01;  // the files give none: RTK, as their README says
    for (const auto& [k, v] : sets) paramTable().setText(p, k, v);
    return p;
  };
  auto run = [&](const std::string& method, const Params& p) {
    const GeoreferenceResult r = georeference(split.run, p);
    printRow(name, method, heldOutError(r, p, split.held_out, lag), r);
    return r;
  };
  Params published = make(false, 0.0);
  published.max_time_offset = 0.0;  // the GNSS at the poses' stamps as given
  published.smooth_jitter = false;
  run("published method", published);
  run("fusion: false", make(false, Params().refine_fraction));
  const Params defaults = make(true, Params().refine_fraction);
  const GeoreferenceResult d = run("defaults", defaults);
  Params given = make(false, Params().refine_fraction);
  given.gnss_time_offset = d.fusion->time_offset;
  given.max_time_offset = 0.0;
  run("fusion: false, the defaults' clock offset", given);
}

}  // namespace flexcloud::study
