// flexcloud_accuracy: the accuracy study of doc/ACCURACY.md. Simulated drives (RTK and urban
// GNSS, loop and open route) are georeferenced by the published method and by flexcloud and
// judged against the simulator's ground truth: map RMSE by distance from the route, trajectory
// RMSE. Prints a markdown table.
//   flexcloud_accuracy [--seeds 1,2,3] [--map-points N] [--scenarios loop_rtk,open_urban,...]
//                      [--set KEY=VALUE ...]
//   flexcloud_accuracy --real DIR[,DIR...] [--holdout N]   the leave-out study of real drives

#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "cli.h"
#include "flexcloud/georeference.h"
#include "flexcloud/io/memory.h"
#include "flexcloud/sim/scenarios.h"
#include "flexcloud/sim/truth_metrics.h"
#include "real_drives.h"
#include "truth_drives.h"
#include "truth_maps.h"

namespace {

using namespace flexcloud;

constexpr const char* kUsage = R"(usage: flexcloud_accuracy [options]
Georeferences simulated drives with the published method and with flexcloud and prints their
errors against the ground truth (doc/ACCURACY.md).
  --seeds N[,N...]          simulator seeds (default 1,2,3)
  --map-points N            map points per drive (default 100000)
  --scenarios A[,B...]      loop_rtk, open_rtk, loop_urban, open_urban, open_urban_end,
                            loop_urban_nocov, loop_offset_lever, open_rtk_drifting
                            (default: the first five)
  --control-points N        (default 200)
  --set KEY=VALUE           a flexcloud parameter (repeatable)
  --only-flexcloud          leave out the published method
  --real DIR[,DIR...]       instead: real drives (slam_poses_tum.txt, gnss_local_at_poses.txt),
                            every N-th fix held out of the run and the trajectory compared with
                            it at its true instant, whatever clock a method chose: the GNSS's
                            lead on the SLAM read from the drive by local rigid fits, shown
                            beside its name (MAE, MAX, RMSE in metres)
  --holdout N               with --real: hold out every N-th fix (default 4)
  --truth-drives DIR[,DIR...]
                            instead: real drives with a ground truth (poses_tum.txt, gt_tum.txt,
                            gnss_rtk.txt and/or gnss_urban.txt, e.g. ../shared/data/kitti_lo/01):
                            the published method, fusion: false and the defaults on each, the
                            trajectory against the truth at the poses' true instants: horizontal
                            RMSE, MAX, MAX in the first and last 20 s and elsewhere, fixes
                            rejected of those that took part, fixes more than 3 m off the truth
                            rejected, the clock's error, the 95th percentile of the
                            orientations' angle from the truth, and from the truth turned by
                            the LiDAR's mount where the truth is of another body (MulRan's
                            base), in all and about each body axis, and the rotation that
                            fits each drive best; then how the defaults' pose sigmas
                            cover the errors: the shares within 2.45 sigma_h and 1.96 sigma_v,
                            the band calibrated sigmas show on as many independent samples,
                            per drive and pooled
  --truth-maps DIR[,DIR...]
                            instead: on the same drives, a map as a LiDAR SLAM makes it (a scan
                            every 5th pose, the ground, walls and poles 2-50 m out, placed by the
                            SLAM's poses; its truth placed by the true poses), moved by the
                            defaults' rubber sheet and by each point's own fused pose: horizontal
                            and vertical RMSE / p95 / MAX, by distance from the point's pose and
                            away from revisits (m)
  --shift S                 with --truth-drives: the poses' stamps moved by S seconds (a known
                            clock offset) (default 0)
  -h, --help
)";

struct Options {
  std::vector<std::uint64_t> seeds{1, 2, 3};
  std::size_t map_points = 100000;
  std::vector<std::string> scenarios{"loop_rtk", "open_rtk", "loop_urban", "open_urban",
                                     "open_urban_end"};
  int control_points = 200;
  std::vector<std::pair<std::string, std::string>> sets;
  bool published = true;
  std::vector<std::string> real;
  std::size_t holdout = 4;
  std::vector<std::string> truth_drives;
  std::vector<std::string> truth_maps;
  double shift = 0.0;
};

Options parse(int argc, char** argv) {
  Options o;
  cli::forEachFlag(argc, argv, kUsage, [&](const std::string& f, cli::Args& a) {
    if (f == "--seeds") {
      o.seeds.clear();
      for (const auto& s : cli::items(a.text(f))) o.seeds.push_back(std::stoull(s));
    } else if (f == "--map-points") {
      o.map_points = static_cast<std::size_t>(a.integer(f));
    } else if (f == "--scenarios") {
      o.scenarios = cli::items(a.text(f));
    } else if (f == "--control-points") {
      o.control_points = static_cast<int>(a.integer(f));
    } else if (f == "--set") {
      o.sets.push_back(cli::keyValue(f, a.text(f)));
    } else if (f == "--only-flexcloud") {
      o.published = false;
    } else if (f == "--real") {
      o.real = cli::items(a.text(f));
    } else if (f == "--truth-drives") {
      o.truth_drives = cli::items(a.text(f));
    } else if (f == "--truth-maps") {
      o.truth_maps = cli::items(a.text(f));
    } else if (f == "--shift") {
      o.shift = a.number(f);
    } else if (f == "--holdout") {
      const long n = a.integer(f);
      if (n < 2) throw cli::UsageError("--holdout: " + std::to_string(n) + " is below 2");
      o.holdout = static_cast<std::size_t>(n);
    } else {
      return false;
    }
    return true;
  });
  return o;
}

/// The published method: GNSS at the poses, control points every len/N, no refinement, no
/// fusion, no points beside the road.
Params published(int control_points) {
  Params p;
  p.fusion = false;
  p.max_time_offset = 0.0;  // the GNSS at the poses' stamps as given
  p.smooth_jitter = false;
  p.refine_fraction = 0.0;
  p.control_points = control_points;
  p.default_std_dev = 0.05;  // fixes without covariance pass the std-dev threshold
  return p;
}

void row(const std::string& name, std::uint64_t seed, const std::string& method,
         const sim::MapTruthErrors& m, const ErrorStats& traj, const GeoreferenceResult& r) {
  std::printf("| %s | %lu | %s | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %s |\n", name.c_str(),
              static_cast<unsigned long>(seed), method.c_str(), m.all.rmse, m.near.rmse, m.mid.rmse,
              m.far.rmse, m.all.max, traj.rmse, study::notesOf(r).c_str());
  std::fflush(stdout);
}

void runOne(const Options& o, const std::string& name, std::uint64_t seed) {
  const sim::SimParams sp = sim::scenario(name, seed, o.map_points);
  const sim::SimDrive d = sim::simulateDrive(sp);
  const DriveInput in = sim::driveInput(d);
  auto atDatum = [&](Params p) { return sim::atSimDatum(d, std::move(p)); };
  if (o.published) {
    const GeoreferenceResult r = georeference(in, atDatum(published(o.control_points)));
    row(name, seed, "published", sim::mapTruthErrors(d.map, *r.sheet),
        sim::trajectoryTruthError(r.rubbersheet, d.truth), r);
  }
  Params p = atDatum(Params{});
  p.control_points = o.control_points;
  if (name == "loop_offset_lever") {
    p.lever_arm_x = sp.lever_arm.x(), p.lever_arm_y = sp.lever_arm.y();
    p.lever_arm_z = sp.lever_arm.z();
  }
  for (const auto& [k, v] : o.sets) paramTable().setText(p, k, v);
  const GeoreferenceResult r = georeference(in, p);
  row(name, seed, "flexcloud", sim::mapTruthErrors(d.map, *r.sheet),
      sim::trajectoryTruthError(r.rubbersheet, d.truth), r);
}

}  // namespace

int main(int argc, char** argv) {
  flexcloud::keepFreedMemory();
  try {
    const Options o = parse(argc, argv);
    if (!o.truth_maps.empty()) {
      study::printTruthMapRows(o.truth_maps, o.control_points, o.sets);
      return 0;
    }
    if (!o.truth_drives.empty()) {
      std::printf(
          "| drive | method | RMSE | MAX | MAX first/last 20 s | MAX elsewhere | fixes rejected | "
          "of those 3 m off | clock error | orientation p95 (deg) | less the mount: all "
          "(about x / y / z) | fitted mount (deg) |\n"
          "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
      study::printTruthDriveRows(o.truth_drives, o.control_points, o.sets, o.shift);
      return 0;
    }
    if (!o.real.empty()) {
      std::printf(
          "| drive | method | held-out MAE | MAX | RMSE | fixes | notes |\n"
          "|---|---|---:|---:|---:|---:|---|\n");
      for (const auto& dir : o.real) {
        study::printRealDriveRows(dir, o.holdout, o.control_points, o.sets);
      }
      return 0;
    }
    std::printf(
        "| drive | seed | method | map RMSE | 0-5 m | 5-15 m | 15-30 m | map MAX | "
        "trajectory RMSE | notes |\n|---|---:|---|---:|---:|---:|---:|---:|---:|---|\n");
    for (const auto& name : o.scenarios) {
      for (std::uint64_t seed : o.seeds) runOne(o, name, seed);
    }
    return 0;
  } catch (const cli::UsageError& e) {
    std::cerr << "flexcloud_accuracy: " << e.what() << " (see --help)" << std::endl;
    return 2;
  } catch (const Error& e) {
    std::cerr << "flexcloud_accuracy: " << e.what() << " (see --help)" << std::endl;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "flexcloud_accuracy: " << e.what() << std::endl;
    return 1;
  }
}
