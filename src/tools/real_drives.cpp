#include "real_drives.h"

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/io/text_io.h"

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

ErrorStats heldOutError(const GeoreferenceResult& r, const Params& p,
                        const std::vector<GnssPoint>& held_out) {
  const double offset = r.clock_offset;
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
  if (r.leave_out) {
    const auto& c = r.leave_out->candidates;
    std::snprintf(buf, sizeof(buf), " (leave-out MAE/MAX fusion %.3f/%.3f, gnss %.3f/%.3f)",
                  c[0].error.mae, c[0].error.max, c[1].error.mae, c[1].error.max);
    out += buf;
  }
  if (r.speed_clock && r.speed_clock->observable) {
    std::snprintf(buf, sizeof(buf), ", clock %.4f +- %.4f s from the speeds%s",
                  r.speed_clock->offset, r.speed_clock->sigma,
                  std::isfinite(r.clock_offset_sigma) ? "" : " (within its noise: not applied)");
    out += buf;
  }
  if (!r.fusion) return out;
  const FusionResult& f = *r.fusion;
  std::snprintf(buf, sizeof(buf), ", dt %.4f s%s, %zu rejected, SLAM noise x%.2f, %.2f + %.2f s",
                f.time_offset, f.time_offset_estimated ? "" : " (fixed)", f.outliers,
                f.slam_noise_scale, f.seconds, r.seconds.leave_out);
  out += buf;
  if (std::isfinite(f.estimated_std_h)) {
    std::snprintf(buf, sizeof(buf), ", std-dev %.3f m estimated", f.estimated_std_h);
    out += buf;
  }
  return out;
}

void printRealDriveRows(const std::string& dir, std::size_t every, int control_points,
                        const std::vector<std::pair<std::string, std::string>>& sets) {
  const LeaveOutSplit split = holdOut(loadRealDrive(dir), every);
  const std::string name = std::filesystem::path(dir).filename().string();
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
    printRow(name, method, heldOutError(r, p, split.held_out), r);
    return r;
  };
  Params published = make(false, 0.0);
  published.max_time_offset = 0.0;  // the GNSS at the poses' stamps as given
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
