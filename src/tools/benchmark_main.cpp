// flexcloud_benchmark: speed and memory of the warp, the PCD I/O and the whole offline tool.
// Prints a markdown table (doc/BENCHMARKS.md holds the figures of the reference machine).
//   flexcloud_benchmark [--points 1000000,10000000] [--control-points 50,200,2000]
//                       [--threads N] [--work DIR] [--repeat N] [--skip-tool]

#include <pcl/io/pcd_io.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <thread>

#include "cli.h"
#include "flexcloud/georeference.h"
#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/memory.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/io/text_io.h"
#include "flexcloud/sim/sim_cloud.h"
#include "flexcloud/sim/truth_metrics.h"
#include "flexcloud/uncertainty/point_sigma.h"
#include "flexcloud/warp/cloud_warp.h"

namespace {

using namespace flexcloud;
namespace fs = std::filesystem;

constexpr const char* kUsage = R"(usage: flexcloud_benchmark [options]
Speed and memory of the warp, the PCD I/O and the whole offline tool on simulated maps; prints a
markdown table (doc/BENCHMARKS.md).
  --points N[,N...]           map sizes (default 1000000,10000000)
  --control-points N[,N...]   (default 50,200,2000)
  --threads N                 warp threads (default: all cores)
  --work DIR                  scratch folder (default: the temporary folder)
  --repeat N                  runs per figure, the best counts (default 3)
  --skip-tool                 leave out the whole-tool runs
  --real DIR                  also a real drive (slam_poses_tum.txt, gnss_local_at_poses.txt;
                              scripts/benchmark.sh passes ../shared/data/a2rl where it is):
                              the pipeline without a map and the fusion apart
  --city N                    also a city-size map of N points (default 100000000; 0: none) in
                              random order, 200 control points: the whole tool against a
                              user-space copy of the file (alternating, each after a sync, the
                              best of --repeat each) and its peak memory, and once with the
                              Autoware tiles
  -h, --help
)";

struct Options {
  std::vector<std::size_t> points{1000000, 10000000};
  std::vector<int> control_points{50, 200, 2000};
  int threads = 0;
  int repeat = 3;
  bool tool = true;
  std::size_t city = 100000000;
  std::string real;
  std::string work = (fs::temp_directory_path() / "flexcloud_benchmark").string();
};

std::vector<double> numbers(const std::string& text) {
  std::vector<double> out;
  for (const auto& item : cli::items(text)) out.push_back(std::stod(item));
  return out;
}

Options parse(int argc, char** argv) {
  Options o;
  cli::forEachFlag(argc, argv, kUsage, [&](const std::string& f, cli::Args& a) {
    if (f == "--points") {
      o.points.clear();
      for (double v : numbers(a.text(f))) o.points.push_back(static_cast<std::size_t>(v));
    } else if (f == "--control-points") {
      o.control_points.clear();
      for (double v : numbers(a.text(f))) o.control_points.push_back(static_cast<int>(v));
    } else if (f == "--threads") {
      o.threads = static_cast<int>(a.integer(f));
    } else if (f == "--repeat") {
      o.repeat = static_cast<int>(a.integer(f));
    } else if (f == "--work") {
      o.work = a.text(f);
    } else if (f == "--city") {
      o.city = static_cast<std::size_t>(a.number(f));
    } else if (f == "--skip-tool") {
      o.tool = false;
    } else if (f == "--real") {
      o.real = a.text(f);
    } else {
      return false;
    }
    return true;
  });
  return o;
}

double seconds(const std::function<void()>& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Best of `n` runs: the least disturbed by whatever else the machine does.
double best(int n, const std::function<void()>& f) {
  double b = 1e300;
  for (int i = 0; i < n; ++i) b = std::min(b, seconds(f));
  return b;
}

struct ProcessRun {
  int code = -1;
  double seconds = 0.0;
  double max_rss_mb = 0.0;
};

/// Runs a program and measures its wall time and peak resident memory; its standard error goes
/// to `err` where one is given.
ProcessRun runProcess(const std::vector<std::string>& args, const std::string& err = "") {
  ProcessRun r;
  const auto t0 = std::chrono::steady_clock::now();
  std::fflush(stdout);
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (std::freopen("/dev/null", "w", stdout) == nullptr) ::_exit(126);
    if (!err.empty() && std::freopen(err.c_str(), "w", stderr) == nullptr) ::_exit(126);
    std::vector<char*> argv;
    for (const auto& s : args) argv.push_back(const_cast<char*>(s.c_str()));
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  int status = 0;
  struct rusage usage {};
  ::wait4(pid, &status, 0, &usage);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.max_rss_mb = static_cast<double>(usage.ru_maxrss) / 1024.0;  // kB on Linux
  return r;
}

std::string toolPath() {
  char self[4096];
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof(self) - 1);
  self[n > 0 ? n : 0] = '\0';
  return (fs::path(self).parent_path() / "georeference").string();
}

/// The same points in random order: the worst case for the location (a SLAM map is stored scan
/// by scan, so neighbours in the file are neighbours in space).
pcl::PCLPointCloud2 shuffled(const pcl::PCLPointCloud2& original) {
  const std::size_t n = static_cast<std::size_t>(original.width) * original.height;
  pcl::PCLPointCloud2 out = original;
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::mt19937_64 rng(7);
  std::shuffle(order.begin(), order.end(), rng);
  const std::size_t step = original.point_step;
  for (std::size_t i = 0; i < n; ++i) {
    std::copy_n(original.data.begin() + order[i] * step, step, out.data.begin() + i * step);
  }
  return out;
}

/// Seconds to write and read the map as a binary PCD, ours and PCL's.
struct IoTimes {
  double write = 0.0, read = 0.0, pcl_write = 0.0, pcl_read = 0.0;
};

IoTimes benchmarkPcdIo(const Options& o, const pcl::PCLPointCloud2& original,
                       const std::string& dir, const std::string& pcd) {
  const std::size_t n = static_cast<std::size_t>(original.width) * original.height;
  const double mb = static_cast<double>(original.data.size()) / 1e6;
  IoTimes t;
  t.write = best(o.repeat, [&] { writePcdBinary(pcd, original); });
  t.read = best(o.repeat, [&] { readPcd(pcd); });
  std::printf("| %zu | PCD write (binary) | | %.3f s | %.1f M/s | cloud %.0f MB |\n", n, t.write,
              n / t.write / 1e6, mb);
  std::printf("| %zu | PCD read (binary) | | %.3f s | %.1f M/s | |\n", n, t.read, n / t.read / 1e6);
  t.pcl_write = best(o.repeat, [&] { pcl::PCDWriter().writeBinary(dir + "/pcl.pcd", original); });
  t.pcl_read = best(o.repeat, [&] {
    pcl::PCLPointCloud2 c;
    pcl::PCDReader().read(dir + "/pcl.pcd", c);
  });
  std::printf(
      "| %zu | PCL's PCD write / read (binary), for reference | | %.3f / %.3f s | %.1f / "
      "%.1f M/s | |\n",
      n, t.pcl_write, t.pcl_read, n / t.pcl_write / 1e6, n / t.pcl_read / 1e6);
  return t;
}

/// The drive as the offline tool's text input; returns the GNSS and pose file paths.
std::pair<std::string, std::string> writeToolInputs(const sim::SimDrive& d,
                                                    const std::string& dir) {
  std::ostringstream g;
  g.precision(12);
  for (const auto& f : d.fixes) {
    g << f.fix.stamp << ' ' << f.fix.lat << ' ' << f.fix.lon << ' ' << f.fix.alt << ' '
      << f.fix.std_enu.x() << ' ' << f.fix.std_enu.y() << ' ' << f.fix.std_enu.z() << '\n';
  }
  writeTextFile(dir + "/gnss.txt", g.str());
  writeTextFile(dir + "/poses.txt", formatTum(d.slam));
  return {dir + "/gnss.txt", dir + "/poses.txt"};
}

/// Warp throughput in memory, in scan order and in random order.
void benchmarkWarp(const Options& o, int cps, const GeoreferenceResult& r,
                   const pcl::PCLPointCloud2& original, const pcl::PCLPointCloud2& random) {
  const std::size_t n = static_cast<std::size_t>(original.width) * original.height;
  pcl::PCLPointCloud2 cloud = original;
  // The first warp builds the location grid; the best of the others is the warp alone.
  const double first_s = seconds([&] { warpCloud(cloud, *r.sheet, o.threads); });
  double warp_s = 1e300;
  for (int i = 0; i < o.repeat; ++i) {
    std::copy(original.data.begin(), original.data.end(), cloud.data.begin());
    warp_s = std::min(warp_s, seconds([&] { warpCloud(cloud, *r.sheet, o.threads); }));
  }
  std::printf(
      "| %zu | warp (locate + transform) | %d (%zu tetrahedra) | %.3f s | **%.1f M/s** | "
      "first warp, with the location grid built: %.3f s |\n",
      n, cps, r.sheet->numTetrahedra(), warp_s, n / warp_s / 1e6, first_s);
  double shuffled_s = 1e300;
  for (int i = 0; i < o.repeat; ++i) {
    pcl::PCLPointCloud2 c = random;
    shuffled_s = std::min(shuffled_s, seconds([&] { warpCloud(c, *r.sheet, o.threads); }));
  }
  std::printf("| %zu | warp, points in random order (worst case) | %d | %.3f s | %.1f M/s | |\n", n,
              cps, shuffled_s, n / shuffled_s / 1e6);
}

/// The warp with every point's sigmas (point_sigma), in scan and in random order, against the
/// warp alone (the rows above): what the sigmas cost. The node and the tool warp rows widened by
/// room for the sigmas (widenPoints), which the warp fills; the widening is a copy either makes
/// anyway (the node's of the map message, the tool's as each chunk is read) and not timed here.
void benchmarkWarpWithSigmas(const Options& o, const GeoreferenceResult& r,
                             const pcl::PCLPointCloud2& original,
                             const pcl::PCLPointCloud2& random) {
  const std::size_t n = static_cast<std::size_t>(original.width) * original.height;
  const PointSigmaField field(r.rubbersheet, r.sigma, *r.sheet);
  const std::size_t step = original.point_step, wide_step = step + kPointSigmaBytes;
  std::vector<std::uint8_t> wide(n * wide_step);
  XyzLayout wide_layout = xyzLayout(original, "map");
  wide_layout.point_step = wide_step;
  for (const pcl::PCLPointCloud2* in : {&original, &random}) {
    pcl::PCLPointCloud2 cloud = *in;
    const XyzLayout layout = xyzLayout(cloud, "map");
    double alone = 1e300, rows = 1e300;
    for (int i = 0; i < o.repeat; ++i) {  // paired, alternating: the machine's noise shared
      std::copy(in->data.begin(), in->data.end(), cloud.data.begin());
      alone = std::min(
          alone, seconds([&] { warpPoints(cloud.data.data(), layout, *r.sheet, o.threads); }));
      widenPoints(in->data.data(), step, n, wide.data());
      rows = std::min(rows, seconds([&] {
                        warpPoints(wide.data(), wide_layout, *r.sheet, o.threads, "map",
                                   neverCancelled(), {&field, wide.data() + step, wide_step});
                      }));
    }
    std::printf(
        "| %zu | warp with point sigmas%s, into the widened rows | | %.3f s | %.1f M/s | %.2fx "
        "the warp alone (%.3f s) |\n",
        n, in == &original ? "" : ", random order", rows, n / rows / 1e6, rows / alone, alone);
  }
}

/// A map saved with per-point time (simulate_drive --map-time) rebuilt from its points' poses
/// (pose_rebuild.h), in scan and in random order, against the warp of the same rows by the sheet
/// (paired, alternating); and rebuilt with point sigmas, into rows widened for them.
void benchmarkRebuild(const Options& o, const GeoreferenceResult& r, const sim::SimDrive& d) {
  const pcl::PCLPointCloud2 timed = sim::slamCloud(d.map, true);
  const pcl::PCLPointCloud2 random = shuffled(timed);
  const std::size_t n = static_cast<std::size_t>(timed.width) * timed.height;
  const PoseCorrections corrections(r.poses, resultPoses(r), r.T_enu_map);
  const PoseRebuild rebuild{*pointPoseField(timed.fields, "auto", "map"), &corrections};
  const PointSigmaField field(r.rubbersheet, r.sigma, *r.sheet);
  const std::size_t step = timed.point_step, wide_step = step + kPointSigmaBytes;
  std::vector<std::uint8_t> wide(n * wide_step);
  XyzLayout wide_layout = xyzLayout(timed, "map");
  wide_layout.point_step = wide_step;
  for (const pcl::PCLPointCloud2* in : {&timed, &random}) {
    pcl::PCLPointCloud2 cloud = *in;
    const XyzLayout layout = xyzLayout(cloud, "map");
    double warp = 1e300, rebuilt = 1e300, with_sigmas = 1e300;
    for (int i = 0; i < o.repeat; ++i) {
      std::copy(in->data.begin(), in->data.end(), cloud.data.begin());
      warp = std::min(warp,
                      seconds([&] { warpPoints(cloud.data.data(), layout, *r.sheet, o.threads); }));
      std::copy(in->data.begin(), in->data.end(), cloud.data.begin());
      rebuilt = std::min(
          rebuilt, seconds([&] { rebuildPoints(cloud.data.data(), layout, rebuild, o.threads); }));
      widenPoints(in->data.data(), step, n, wide.data());
      with_sigmas =
          std::min(with_sigmas, seconds([&] {
                     rebuildPoints(wide.data(), wide_layout, rebuild, o.threads, "map",
                                   neverCancelled(), {&field, wide.data() + step, wide_step});
                   }));
    }
    const char* order = in == &timed ? "" : ", random order";
    std::printf(
        "| %zu | rebuild from per-point time%s | | %.3f s | %.1f M/s | %.2fx the warp of the same "
        "rows (%.3f s) |\n",
        n, order, rebuilt, n / rebuilt / 1e6, rebuilt / warp, warp);
    std::printf(
        "| %zu | rebuild with point sigmas%s, into the widened rows | | %.3f s | %.1f M/s | %.2fx "
        "the warp |\n",
        n, order, with_sigmas, n / with_sigmas / 1e6, with_sigmas / warp);
  }
}

/// The whole offline tool on a map file: best wall time of `repeat` runs and its own peak
/// memory.
ProcessRun toolRun(const Options& o, int cps, const std::pair<std::string, std::string>& inputs,
                   const std::string& pcd, const std::string& dir, int repeat) {
  ProcessRun t;
  t.seconds = 1e300;
  for (int k = 0; k < repeat; ++k) {
    const ProcessRun run =
        runProcess({toolPath(), "--gnss", inputs.first, "--poses", inputs.second, "--map", pcd,
                    "--out", dir + "/out", "--control-points", std::to_string(cps), "--threads",
                    std::to_string(o.threads), "-q"});
    if (run.code != 0) {
      throw Error("the georeference tool failed with exit code " + std::to_string(run.code));
    }
    t.seconds = std::min(t.seconds, run.seconds);
  }
  // The tool's own peak (VmHWM): a forked child's ru_maxrss would include this process.
  std::ifstream report(dir + "/out/report.json");
  const std::string text((std::istreambuf_iterator<char>(report)), {});
  const auto at = text.find("\"peak_memory_mb\":");
  t.max_rss_mb = at == std::string::npos ? 0.0 : std::stod(text.substr(at + 17));
  return t;
}

void benchmarkTool(const Options& o, int cps, const std::pair<std::string, std::string>& inputs,
                   const std::string& pcd, const std::string& dir, std::size_t n, double mb,
                   const IoTimes& io) {
  const ProcessRun t = toolRun(o, cps, inputs, pcd, dir, o.repeat);
  std::printf(
      "| %zu | whole offline tool | %d | %.3f s | %.1f M/s | peak %.0f MB = **%.2f x** "
      "cloud; **%.2f x** (read + write), %.2f x PCL's |\n",
      n, cps, t.seconds, n / t.seconds / 1e6, t.max_rss_mb, t.max_rss_mb / mb,
      t.seconds / (io.read + io.write), t.seconds / (io.pcl_read + io.pcl_write));
}

/// The whole tool on the same map as an ascii and as a binary_compressed PCD (PCL's writers),
/// once each: streamed as well.
void benchmarkEncodings(const Options& o, const pcl::PCLPointCloud2& cloud,
                        const std::pair<std::string, std::string>& inputs, const std::string& dir) {
  const double mb = static_cast<double>(cloud.data.size()) / 1e6;
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  for (const bool ascii : {true, false}) {
    const std::string path = dir + (ascii ? "/map_ascii.pcd" : "/map_compressed.pcd");
    const int rc = ascii ? pcl::PCDWriter().writeASCII(path, cloud)
                         : pcl::PCDWriter().writeBinaryCompressed(path, cloud);
    if (rc != 0) throw Error(path + ": PCL could not write it");
    const double file_mb = static_cast<double>(fs::file_size(path)) / 1e6;
    const ProcessRun t = toolRun(o, 200, inputs, path, dir, 1);
    std::printf(
        "| %zu | whole offline tool, %s map (%.0f MB file) | 200 | %.3f s | %.1f M/s | peak "
        "%.0f MB = **%.2f x** cloud |\n",
        n, ascii ? "ascii" : "binary_compressed", file_mb, t.seconds, n / t.seconds / 1e6,
        t.max_rss_mb, t.max_rss_mb / mb);
    std::fflush(stdout);
    fs::remove(path);
  }
}

void onePointCount(const Options& o, std::size_t n) {
  sim::SimParams sp;
  sp.map_points = n;
  std::fprintf(stderr, "simulating a 5 km drive with %zu map points\n", n);
  const sim::SimDrive d = sim::simulateDrive(sp);
  const pcl::PCLPointCloud2 original = sim::slamCloud(d.map);
  const pcl::PCLPointCloud2 random = shuffled(original);
  const std::string dir = o.work + "/n" + std::to_string(n);
  makeDirectories(dir);
  const std::string pcd = dir + "/map.pcd";
  const IoTimes io = benchmarkPcdIo(o, original, dir, pcd);
  const auto inputs = writeToolInputs(d, dir);
  const DriveInput in = sim::driveInput(d);
  for (int cps : o.control_points) {
    Params p;
    p.control_points = cps;
    p.threads = o.threads;
    const GeoreferenceResult r = georeference(in, p);
    benchmarkWarp(o, cps, r, original, random);
    benchmarkWarpWithSigmas(o, r, original, random);
    if (cps == 200) benchmarkRebuild(o, r, d);
    if (o.tool) {
      benchmarkTool(o, cps, inputs, pcd, dir, n, static_cast<double>(original.data.size()) / 1e6,
                    io);
    }
    std::fflush(stdout);
  }
  if (o.tool) benchmarkEncodings(o, original, inputs, dir);
}

/// A user-space copy of a file through a 4 MB buffer (what cp does): the floor for a tool that
/// reads a map and writes it again.
double copyFile(const std::string& from, const std::string& to) {
  return seconds([&] {
    std::ifstream in(from, std::ios::binary);
    std::ofstream out(to, std::ios::binary | std::ios::trunc);
    std::vector<char> buf(4 << 20);
    while (in.read(buf.data(), static_cast<std::streamsize>(buf.size())) || in.gcount() > 0) {
      out.write(buf.data(), in.gcount());
    }
    if (!out) throw Error(to + ": the copy failed");
  });
}

/// The tool's own peak memory from its report.
/// What a run of the tool says of itself in its report.json.
struct ToolReport {
  double peak_mb = 0.0;
  std::string stages;  ///< the map stages' seconds as a note ("" where not reported)
};

ToolReport readToolReport(const std::string& report_path) {
  std::ifstream report(report_path);
  const nlohmann::json j = nlohmann::json::parse(report, nullptr, false);
  ToolReport out;
  if (j.is_discarded()) return out;
  if (j.contains("peak_memory_mb") && j["peak_memory_mb"].is_number()) {
    out.peak_mb = j["peak_memory_mb"].get<double>();
  }
  if (j.contains("seconds")) {
    const auto& s = j["seconds"];
    char buf[160];
    std::snprintf(buf, sizeof(buf), "; map read %.1f, location grid %.1f, warp %.1f, write %.1f s",
                  s.value("map_read", 0.0), s.value("map_location_grid", 0.0),
                  s.value("map_warp", 0.0), s.value("map_write", 0.0));
    out.stages = buf;
  }
  return out;
}

/// The best and the worst of the tool's runs on the city map, with the best one's report.
struct CityRun {
  double best = 1e300, worst = 0.0;
  std::size_t runs = 0;
  ToolReport report;
  void add(const std::pair<double, ToolReport>& run) {
    ++runs;
    worst = std::max(worst, run.first);
    if (run.first < best) best = run.first, report = run.second;
  }
};

/// One run of the whole tool on the city map: its seconds and its report.
std::pair<double, ToolReport> cityToolRun(const Options& o,
                                          const std::pair<std::string, std::string>& inputs,
                                          const std::string& pcd, const std::string& dir,
                                          bool autoware) {
  std::vector<std::string> args = {toolPath(),
                                   "--gnss",
                                   inputs.first,
                                   "--poses",
                                   inputs.second,
                                   "--map",
                                   pcd,
                                   "--out",
                                   dir + "/out",
                                   "--threads",
                                   std::to_string(o.threads),
                                   "-q"};
  if (autoware) args.push_back("--autoware");
  const ProcessRun run = runProcess(args);
  if (run.code != 0) throw Error("the georeference tool failed on the city map");
  return {run.seconds, readToolReport(dir + "/out/report.json")};
}

/// Writes back and deletes the last copy and the last output, then waits `pause` seconds. On a
/// virtual machine that hands freed memory back to its host (free page reporting), 2.4 GB of new
/// page cache costs 0.8 s right after a file that size was deleted and 4-7 s a few seconds
/// later, when the host has taken the memory back: a copy and a tool run compare only in the
/// same state.
void settle(const std::string& dir, double pause) {
  ::sync();
  fs::remove(dir + "/copy.pcd");
  fs::remove_all(dir + "/out");
  std::this_thread::sleep_for(std::chrono::duration<double>(pause));
}

/// Copies and tool runs on the city map in one memory state: the best and the spread of each.
struct CityState {
  CityState(const char* n, double p) : name(n), pause(p) {}
  const char* name;
  double pause;  ///< seconds between freeing the last output and the run
  std::vector<double> copies;
  CityRun tool;
};

void printCityState(const Options& o, const CityState& st, double gb) {
  const double copy = *std::min_element(st.copies.begin(), st.copies.end());
  std::printf(
      "| %zu | user-space copy of the map file (4 MB buffer), %s | | %.3f s | %.1f M/s | "
      "%.2f GB binary, random order; %zu copies: %.2f-%.2f s |\n",
      o.city, st.name, copy, o.city / copy / 1e6, gb, st.copies.size(), copy,
      *std::max_element(st.copies.begin(), st.copies.end()));
  std::printf(
      "| %zu | whole offline tool, random order, %s | 200 | %.3f s | %.1f M/s | **%.2f x** the "
      "copy; %zu run(s): %.2f-%.2f s; peak %.0f MB%s |\n",
      o.city, st.name, st.tool.best, o.city / st.tool.best / 1e6, st.tool.best / copy, st.tool.runs,
      st.tool.best, st.tool.worst, st.tool.report.peak_mb, st.tool.report.stages.c_str());
}

/// The pipeline without a map on `in`: the best time of o.repeat runs and the last run's result.
std::pair<GeoreferenceResult, double> timedPipeline(const Options& o, const DriveInput& in,
                                                    Params p) {
  p.threads = o.threads;
  GeoreferenceResult r;
  const double s = best(o.repeat, [&] { r = georeference(in, p); });
  return {std::move(r), s};
}

/// A city-size map (a 20 km drive) in random order: the whole tool against a copy of the file.
void cityMap(const Options& o) {
  const std::string dir = o.work + "/city";
  makeDirectories(dir);
  const std::string pcd = dir + "/map.pcd";
  std::pair<std::string, std::string> inputs;
  std::size_t bytes = 0;
  {
    sim::SimParams sp;
    sp.length = 20000.0;
    sp.map_points = o.city;
    std::fprintf(stderr, "simulating a 20 km drive with %zu map points\n", o.city);
    const sim::SimDrive d = sim::simulateDrive(sp);
    inputs = writeToolInputs(d, dir);
    const pcl::PCLPointCloud2 random = shuffled(sim::slamCloud(d.map));
    bytes = random.data.size();
    writePcdBinary(pcd, random);
    if (o.tool) benchmarkEncodings(o, random, inputs, dir);
  }
  const double gb = static_cast<double>(bytes) / 1e9;
  // Copies and tool runs alternate in each state, the best of each compared (see settle()).
  std::array<CityState, 2> states = {CityState{"right after the last output was deleted", 0.0},
                                     CityState{"5 s after it", 5.0}};
  copyFile(pcd, dir + "/copy.pcd");  // a file of the map's size for the first run to free
  for (int i = 0; i < o.repeat; ++i) {
    for (CityState& st : states) {
      settle(dir, st.pause);
      st.copies.push_back(copyFile(pcd, dir + "/copy.pcd"));
      settle(dir, st.pause);
      st.tool.add(cityToolRun(o, inputs, pcd, dir, false));
    }
  }
  settle(dir, 0.0);
  CityRun tiles;
  tiles.add(cityToolRun(o, inputs, pcd, dir, true));
  for (const CityState& st : states) printCityState(o, st, gb);
  std::printf(
      "| %zu | whole offline tool, random order, with the 20 m Autoware tiles, right after the "
      "last output was deleted | 200 | %.3f s | %.1f M/s | peak %.0f MB%s |\n",
      o.city, tiles.best, o.city / tiles.best / 1e6, tiles.report.peak_mb,
      tiles.report.stages.c_str());
  std::fflush(stdout);
  fs::remove_all(dir);
}

void oneHourDrive(const Options& o) {
  sim::SimParams sp;
  sp.length = 12.0 * 3600.0;  // an hour at 12 m/s: 36000 poses at 10 Hz, 18000 fixes at 5 Hz
  sp.map_points = 0;
  const sim::SimDrive d = sim::simulateDrive(sp);
  const DriveInput in = sim::driveInput(d);
  Params p = sim::atSimDatum(d);
  p.control_points = 2000;
  const auto [r, s] = timedPipeline(o, in, p);
  const auto& t = r.seconds;
  std::printf(
      "| - | pipeline without map, one-hour drive (%zu poses, %zu fixes) | 2000 (%zu "
      "tetrahedra) | %.3f s | | interpolation %.3f, alignment %.3f, control points %.3f, "
      "fusion %.3f, trajectory %.3f, pose sigmas %.3f s; trajectory RMSE vs the truth %.3f m |\n",
      r.poses.size(), r.gnss.points.size(), r.sheet->numTetrahedra(), s, t.interpolation,
      t.alignment, t.control_points, t.fusion, t.trajectory_warp, t.sigma,
      sim::trajectoryTruthError(r.rubbersheet, d.truth).rmse);
}

/// The pipeline without a map on a real drive, defaults: the whole, the fusion and the control
/// points.
void realDrive(const Options& o) {
  DriveInput in;
  in.poses = readTumFile(o.real + "/slam_poses_tum.txt");
  in.local_gnss = readLocalGnssFile(o.real + "/gnss_local_at_poses.txt");
  const auto [r, s] = timedPipeline(o, in, Params{});
  const auto& t = r.seconds;
  std::printf(
      "| - | pipeline without map, real drive %s (%zu poses, %zu fixes), defaults | 200 | %.3f s | "
      "| fusion %.3f s (%d stages, %zu keyframes), control points %.3f s, pose sigmas %.3f s "
      "(%.1f %% of the rest) |\n",
      fs::path(o.real).filename().c_str(), r.poses.size(), r.gnss.points.size(), s, t.fusion,
      r.fusion->stages, r.fusion->keyframes, t.control_points, t.sigma,
      100.0 * t.sigma / std::max(s - t.sigma, 1e-9));
  std::fflush(stdout);
}

/// The tool as a user runs it on the real drive without a map, a fresh process each time (the
/// allocator and the caches cold), with report.png drawn or (`png` false) left out: the best
/// wall time of o.repeat runs and that run's pipeline and fusion seconds from its report.json.
void realDriveTool(const Options& o, bool png) {
  const std::string dir = o.work + "/real_drive_tool";
  const std::string log = o.work + "/real_drive_tool.log";
  makeDirectories(o.work);
  std::vector<std::string> args = {toolPath(),     "--gnss",  o.real + "/gnss_local_at_poses.txt",
                                   "--gnss-local", "--poses", o.real + "/slam_poses_tum.txt",
                                   "--out",        dir,       "-q"};
  if (!png) args.insert(args.end(), {"--set", "report_png=false"});
  double wall = 1e300, pipeline = 0.0, fusion = 0.0;
  for (int i = 0; i < o.repeat; ++i) {
    fs::remove_all(dir);
    const ProcessRun run = runProcess(args, log);
    if (run.code != 0) throw Error("the georeference tool failed on " + o.real + ": see " + log);
    if (run.seconds >= wall) continue;
    wall = run.seconds;
    std::ifstream report(dir + "/report.json");
    const nlohmann::json seconds = nlohmann::json::parse(report).at("seconds");
    pipeline = 0.0;
    for (const auto& [stage, value] : seconds.items()) pipeline += value.get<double>();
    fusion = seconds.at("fusion").get<double>();
  }
  fs::remove_all(dir);
  fs::remove(log);
  std::printf(
      "| - | whole offline tool without map, real drive %s, a fresh process, %s | 200 | %.3f s | "
      "| pipeline %.3f s (fusion %.3f s); the rest: the start, the files%s |\n",
      fs::path(o.real).filename().c_str(), png ? "report.png drawn" : "report_png false", wall,
      pipeline, fusion, png ? ", report.png" : "");
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  flexcloud::keepFreedMemory();
  try {
    const Options o = parse(argc, argv);
    std::printf("machine: %u hardware threads; warp threads: %d\n\n",
                std::thread::hardware_concurrency(), resolveThreads(o.threads));
    std::printf("| points | what | control points | time | points/s | notes |\n");
    std::printf("|---:|---|---|---:|---:|---|\n");
    oneHourDrive(o);
    if (!o.real.empty()) realDrive(o);
    if (!o.real.empty() && o.tool) {
      realDriveTool(o, true);
      realDriveTool(o, false);
    }
    for (std::size_t n : o.points) onePointCount(o, n);
    if (o.city > 0) cityMap(o);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "flexcloud_benchmark: " << e.what() << std::endl;
    return 1;
  }
}
