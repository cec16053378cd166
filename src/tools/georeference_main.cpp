// georeference: the offline tool. Reads a drive (bag or text files) and optionally a map,
// georeferences it and writes the outputs into a folder. Exit 0 on success, 1 on bad input or
// a failed run, 2 on a usage mistake, 130 when interrupted; the folder keeps its previous files
// unless the run completes.

#include <ros/time.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>

#include "cli.h"
#include "flexcloud/geo/frame_convert.h"
#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/io/config.h"
#include "flexcloud/io/keyframes.h"
#include "flexcloud/io/map_precopy.h"
#include "flexcloud/io/map_stream.h"
#include "flexcloud/io/memory.h"
#include "flexcloud/io/outputs.h"
#include "flexcloud/io/pcd_header.h"
#include "flexcloud/io/pcd_io.h"
#include "flexcloud/io/pcd_stream.h"
#include "flexcloud/io/report_plot.h"
#include "flexcloud/io/scan_map.h"
#include "flexcloud/io/text_io.h"
#include "flexcloud/ros/bag_input.h"
#include "flexcloud/ros/drive_collector.h"
#include "flexcloud/ros/node_params.h"
#include "flexcloud/uncertainty/point_sigma.h"
#include "flexcloud/warp/cloud_warp.h"

namespace {

using namespace flexcloud;
using cli::UsageError;

constexpr const char* kUsage = R"(usage: georeference INPUT [options]

INPUT, one of:
  --bag FILE              rosbag with sensor_msgs/NavSatFix and nav_msgs/Odometry (or
                          geometry_msgs/PoseStamped, or nav_msgs/Path: the last one is used)
    --fix-topic T         NavSatFix topic (default: the bag's only one)
    --odom-topic T        pose topic (default: the bag's only Odometry/PoseStamped/Path one)
    --scan-topic T        instead of --map: the SLAM's registered scans (PointCloud2 in the
                          poses' frame, as LIO-SAM and FAST-LIO publish them) make the map,
                          each point rebuilt with its scan's pose
  --gnss FILE --poses FILE
                          GNSS "stamp lat lon alt [std_e std_n std_u]" and TUM poses
                          "stamp x y z qx qy qz qw"; separated by spaces, commas,
                          semicolons or tabs; lines starting with # and a first line that
                          is not numbers (a header such as stamp,lat,lon,alt) are skipped
    --gnss-local          GNSS file is "stamp x y z [sx sy sz]" in a local ENU frame (m)
    --gnss-stamp-unit U   auto (default), s, ms, us or ns; auto reads Unix epochs by their
    --poses-stamp-unit U  size (s below 1e10, ms, us, ns above 1e16) and stamps counted
                          from 0 as seconds
    --stamp-unit U        both at once
  --keyframes DIR         with --gnss FILE or --bag FILE (its fixes), instead of the poses
                          and --map: a SLAM's keyframe dump (hdl_graph_slam, interactive_slam:
                          a subfolder per keyframe with data and cloud.pcd); its poses are the
                          trajectory, and the map is rebuilt a keyframe at a time, each moved
                          with its own pose's correction
                          Clocks that differ by a constant (poses from 0, GNSS in Unix
                          time): --set gnss_time_offset=S, the SLAM clock minus the GNSS
                          clock (the error for spans that do not overlap gives S)

options:
  --map FILE.pcd          SLAM map to warp (ascii, binary or binary_compressed; all fields kept)
  --out DIR               output folder (default: flexcloud_out)
  --datum LAT LON ALT     ENU datum (default: the first valid fix)
  --control-points N      number of control points (default {control_points})
  --stddev-threshold M    largest horizontal GNSS std-dev (the larger of east and north) of
                          a fix the alignment and the control points take (default
                          {stddev_threshold}); with the fusion, where it leaves fewer than a
                          quarter of the fixes, every fix is weighed by its std-dev instead
  --config FILE.yaml      parameters, same keys as the ROS node's (config/georeference.yaml;
                          the node's own keys are accepted and not used)
  --set KEY=VALUE         any parameter (repeatable), e.g. --set max_gap=2; every parameter
                          with its default and range: doc/PARAMETERS.md
  --threads N             warp threads (default: all cores)
  --autoware              also write DIR/autoware/: the map in square tiles with
                          pointcloud_map_metadata.yaml and map_projector_info.yaml
    --tile-size M         side of the tiles, whole metres (default {tile_size})
    --projector P         frame of the tiles (default {projector}): local_cartesian (ENU at
                          the datum), local_cartesian_utm or mgrs (reprojected point by point)
  --accept-degraded       keep a result that cannot be right (more than 80 % of the fixes
                          rejected, a rigid scale 5 % off, most of the map far from every
                          pose), marked
                          degraded in report.json; without it such a run fails naming why
  --las                   also write DIR/map_georeferenced.las (LAS 1.4, UTM zone of the datum)
  --point-sigma           give every point of map_georeferenced.pcd (and the Autoware tiles)
                          the fields sigma_h and sigma_v: how far it may lie from its true
                          place, m (doc/OUTPUTS.md)
  --to-ll FILE            also convert the points in FILE ("x y z" per line, map frame) through
                          the result to WGS84: DIR/points_ll.txt "x y z lat lon alt"
  --truth FILE.pcd        ground-truth map (same points, same order) in the ENU frame of the
                          datum in truth.yaml beside it (as simulate_drive writes) or given by
                          --truth-datum LAT LON ALT; the run's datum must be the same (--datum):
                          the report then holds the map error before and after
  -q, --quiet             no progress on stderr
  -h, --help
)";

struct Options {
  std::string bag, fix_topic, odom_topic, gnss, poses, map, truth, config, to_ll, keyframes;
  std::string scan_topic;
  std::optional<Datum> truth_datum;  ///< the datum the truth is in (--truth-datum, truth.yaml)
  std::string out = "flexcloud_out";
  bool gnss_local = false;
  bool quiet = false;
  StampUnit gnss_unit = StampUnit::kAuto;
  StampUnit poses_unit = StampUnit::kAuto;
  std::vector<std::pair<std::string, std::string>> sets;  // applied after the config file
};

/// The usage text with each "{name}" replaced by that parameter's default (and unit) from the
/// parameter table, so the help never spells a default by hand.
std::string withDefaults(std::string text) {
  for (std::size_t at = text.find('{'); at != std::string::npos; at = text.find('{', at)) {
    const std::size_t end = text.find('}', at);
    const ParamSpec& spec = paramTable().row(text.substr(at + 1, end - at - 1)).spec;
    const std::string value =
        formatValue(spec, spec.def) + (spec.unit.empty() ? "" : " " + spec.unit);
    text.replace(at, end - at + 1, value);
    at += value.size();
  }
  return text;
}

/// Options that set one parameter: with a value, and switches that set it to true.
const std::map<std::string, std::string> kValueShortcuts = {
    {"--control-points", "control_points"},
    {"--stddev-threshold", "stddev_threshold"},
    {"--threads", "threads"},
    {"--tile-size", "tile_size"},
    {"--projector", "projector"}};
const std::map<std::string, std::string> kSwitches = {{"--autoware", "autoware"},
                                                      {"--las", "las"},
                                                      {"--accept-degraded", "accept_degraded"},
                                                      {"--point-sigma", "point_sigma"}};

/// The datum of a truth map from truth.yaml in its folder; throws UsageError when there is none
/// (a truth in another ENU frame would report metres of error that are not there).
Datum datumBeside(const std::string& truth) {
  const std::string yaml = (std::filesystem::path(truth).parent_path() / "truth.yaml").string();
  if (!std::filesystem::exists(yaml)) {
    throw UsageError("--truth " + truth + ": give the datum it was made in (--truth-datum LAT " +
                     "LON ALT, or a truth.yaml beside it)");
  }
  try {
    const YAML::Node d = YAML::LoadFile(yaml)["datum"];
    return Datum{d["latitude"].as<double>(), d["longitude"].as<double>(),
                 d["altitude"].as<double>()};
  } catch (const YAML::Exception& e) {
    throw Error(yaml + ": no datum latitude, longitude, altitude (" + e.what() + ")");
  }
}

/// The unit a stamp-unit flag gives; UsageError naming the flag otherwise.
StampUnit stampUnit(const std::string& flag, const std::string& text) {
  try {
    return parseStampUnit(text);
  } catch (const Error& e) {
    throw UsageError(flag + ": " + e.what());
  }
}

/// Every file the options name, checked before any work: a missing map is reported before the
/// bag is read, not after.
void checkInputFiles(const Options& o) {
  const std::pair<const char*, const std::string*> files[] = {
      {"--bag", &o.bag},     {"--gnss", &o.gnss},   {"--poses", &o.poses},  {"--map", &o.map},
      {"--truth", &o.truth}, {"--to-ll", &o.to_ll}, {"--config", &o.config}};
  for (const auto& [flag, path] : files) {
    if (path->empty()) continue;
    std::error_code ec;
    const auto status = std::filesystem::status(*path, ec);
    if (!std::filesystem::exists(status)) {
      throw Error(std::string(flag) + " " + *path + ": no such file");
    }
    if (std::filesystem::is_directory(status)) {
      throw Error(std::string(flag) + " " + *path + ": is a folder, not a file");
    }
    if (!std::ifstream(*path)) throw Error(std::string(flag) + " " + *path + ": cannot be read");
  }
}

Options parseOptions(int argc, char** argv) {
  Options o;
  if (argc < 2) throw UsageError("no input given (--bag, or --gnss with --poses)");
  static const std::string usage = withDefaults(kUsage);
  cli::forEachFlag(argc, argv, usage.c_str(), [&](const std::string& f, cli::Args& a) {
    if (f == "--bag") {
      o.bag = a.text(f);
    } else if (f == "--fix-topic") {
      o.fix_topic = a.text(f);
    } else if (f == "--odom-topic") {
      o.odom_topic = a.text(f);
    } else if (f == "--scan-topic") {
      o.scan_topic = a.text(f);
    } else if (f == "--gnss") {
      o.gnss = a.text(f);
    } else if (f == "--poses") {
      o.poses = a.text(f);
    } else if (f == "--gnss-local") {
      o.gnss_local = true;
    } else if (f == "--stamp-unit") {
      o.gnss_unit = o.poses_unit = stampUnit(f, a.text(f));
    } else if (f == "--gnss-stamp-unit") {
      o.gnss_unit = stampUnit(f, a.text(f));
    } else if (f == "--poses-stamp-unit") {
      o.poses_unit = stampUnit(f, a.text(f));
    } else if (f == "--map") {
      o.map = a.text(f);
    } else if (f == "--keyframes") {
      o.keyframes = a.text(f);
    } else if (f == "--out") {
      o.out = a.text(f);
    } else if (f == "--datum") {
      o.sets.emplace_back("datum_lat", a.text(f));
      o.sets.emplace_back("datum_lon", a.text(f));
      o.sets.emplace_back("datum_alt", a.text(f));
    } else if (const auto v = kValueShortcuts.find(f); v != kValueShortcuts.end()) {
      o.sets.emplace_back(v->second, a.text(f));
    } else if (const auto w = kSwitches.find(f); w != kSwitches.end()) {
      o.sets.emplace_back(w->second, "true");
    } else if (f == "--to-ll") {
      o.to_ll = a.text(f);
    } else if (f == "--config") {
      o.config = a.text(f);
    } else if (f == "--set") {
      o.sets.push_back(cli::keyValue(f, a.text(f)));
    } else if (f == "--truth") {
      o.truth = a.text(f);
    } else if (f == "--truth-datum") {
      const double lat = a.number(f), lon = a.number(f), alt = a.number(f);
      o.truth_datum = Datum{lat, lon, alt};
    } else if (f == "-q" || f == "--quiet") {
      o.quiet = true;
    } else {
      return false;
    }
    return true;
  });
  const bool text = !o.gnss.empty() || !o.poses.empty();
  if (!o.bag.empty() && text) throw UsageError("give --bag or --gnss/--poses, not both");
  if (!o.keyframes.empty()) {
    if (!o.poses.empty() || !o.map.empty() || !o.truth.empty()) {
      throw UsageError("--keyframes gives the poses and the map: no --poses, --map or --truth");
    }
    if (o.bag.empty() && o.gnss.empty()) throw UsageError("--keyframes needs --gnss or --bag");
  } else if (o.bag.empty() && (o.gnss.empty() || o.poses.empty())) {
    throw UsageError("give --bag FILE, or both --gnss FILE and --poses FILE");
  }
  if (!o.scan_topic.empty() && (o.bag.empty() || !o.map.empty() || !o.keyframes.empty())) {
    throw UsageError(
        "--scan-topic reads the map from the bag's scans: with --bag, no --map or "
        "--keyframes");
  }
  if (!o.truth.empty() && o.map.empty()) throw UsageError("--truth needs --map");
  checkInputFiles(o);
  if (!o.truth.empty() && !o.truth_datum) o.truth_datum = datumBeside(o.truth);
  return o;
}

/// The parameters from --config and --set, read through the node's table: a config file
/// written for the node works here too.
Params loadParams(const Options& o) {
  NodeParams p;
  if (!o.config.empty()) loadParamsYaml(o.config, nodeParamTable(), p);
  for (const auto& [k, v] : o.sets) nodeParamTable().setText(p, k, v);
  if (const std::string bad = p.validate(); !bad.empty()) throw Error("parameters: " + bad);
  return p.core;
}

/// Raised by SIGINT and SIGTERM: the run stops at its next check and leaves the output folder
/// as it was. (A signal handler can only reach static storage; the library takes the token.)
CancelToken g_interrupt;

class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet) {}
  void say(const std::string& s) const {
    if (!quiet_) std::cerr << "[georeference] " << s << std::endl;
  }

 private:
  bool quiet_;
};

void checkCancel() { g_interrupt.check("georeference"); }

/// A file in the temporary folder, removed with this object ("" names none).
class TempFile {
 public:
  explicit TempFile(const std::string& name)
      : path_(name.empty() ? ""
                           : (std::filesystem::temp_directory_path() /
                              ("flexcloud_" + name + "_" + std::to_string(::getpid()) + ".pcd"))
                                 .string()) {}
  ~TempFile() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove(path_, ec);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// The bag's scans, gathered into one map (scan_map.h).
struct BagScans {
  std::shared_ptr<pcl::PCLPointCloud2> cloud;
  bool body = false;  ///< in the body's frame: placed by the SLAM's poses before the rebuild
};

/// The map the bag's scans make; throws Error where there is none, or where they are in neither
/// the poses' frame nor their body's.
BagScans bagScans(const Options& o, const BagSummary& s, const DriveCollector& collector) {
  const DriveCollector::Scans scans = collector.scans();
  if (!scans.cloud) throw Error(o.bag + ": no scan on " + s.scan_topic);
  return {scans.cloud, scansInBodyFrame(scans.frame, collector.mapFrame(), collector.bodyFrame(),
                                        o.bag + ": " + s.scan_topic)};
}

/// Writes the scans' map, in the SLAM's map frame, to `path`.
void writeScanMap(const BagScans& scans, const GeoreferenceResult& r, const std::string& path) {
  if (scans.body) placeBodyScans(*scans.cloud, r.poses);
  writePcdBinary(path, *scans.cloud);
}

/// The drive; with --scan-topic, `scans` gets the map the bag's registered scans make.
DriveInput loadDrive(const Options& o, const Progress& log, std::string& map_frame,
                     const std::vector<Keyframe>& keyframes, BagScans* scans = nullptr) {
  if (!keyframes.empty()) {
    log.say("  " + std::to_string(keyframes.size()) + " keyframes in " + o.keyframes);
    DriveInput in = loadDrive(o, log, map_frame, {});  // the fixes (a bag's odometry unread)
    in.poses = keyframePoses(keyframes);
    return in;
  }
  if (!o.bag.empty()) {
    DriveCollector collector;
    log.say("reading " + o.bag);
    BagTopics topics;
    topics.fix = o.fix_topic;
    topics.odom = o.odom_topic;
    topics.fixes_only = !o.keyframes.empty();
    topics.scans = o.scan_topic;
    const BagSummary s = readBag(o.bag, topics, collector, nullptr, [&](double f) {
      log.say("  bag " + std::to_string(static_cast<int>(100 * f)) + "%");
    });
    log.say("  " + std::to_string(s.fixes) + " fixes on " + s.fix_topic +
            (s.odom_topic.empty()
                 ? std::string()
                 : ", " + std::to_string(s.poses) + " " + s.odom_type + " on " + s.odom_topic));
    map_frame = collector.mapFrame().empty() ? "map" : collector.mapFrame();
    if (!o.scan_topic.empty() && scans != nullptr) *scans = bagScans(o, s, collector);
    return collector.snapshot();
  }
  DriveInput in;
  if (o.gnss_local) {
    in.local_gnss = readLocalGnssFile(o.gnss, o.gnss_unit);
  } else {
    in.fixes = readGeodeticGnssFile(o.gnss, o.gnss_unit);
  }
  if (o.keyframes.empty()) in.poses = readTumFile(o.poses, o.poses_unit);
  return in;
}

/// "N of M fixes rejected" (the fusion's outliers among the fixes it judged).
std::string rejectedShare(const GeoreferenceResult& r) {
  if (!r.fusion) return "no fixes rejected (fusion off)";
  std::size_t judged = 0, rejected = 0;
  for (const FixOutcome& f : r.fusion->fixes) {
    judged += f.verdict == FixVerdict::kUsed || f.verdict == FixVerdict::kOutlier;
    rejected += f.verdict == FixVerdict::kOutlier;
  }
  return std::to_string(rejected) + " of " + std::to_string(judged) + " fixes rejected";
}

/// The clock offset applied (SLAM clock minus GNSS clock): estimated with its 1-sigma, or given.
std::string clockPart(const GeoreferenceResult& r) {
  char s[96];
  if (std::isfinite(r.clock_offset_sigma)) {
    std::snprintf(s, sizeof(s), "clock offset %+.1f +- %.1f ms", 1e3 * r.clock_offset,
                  1e3 * r.clock_offset_sigma);
  } else {
    std::snprintf(s, sizeof(s), "clock offset %+.1f ms as given", 1e3 * r.clock_offset);
  }
  return s;
}

/// The SLAM's jitter taken out of the trajectories, if it was: ", SLAM jitter 1.3 cm smoothed".
std::string jitterPart(const GeoreferenceResult& r) {
  if (r.jitter.half_width == 0) return "";
  char s[64];
  std::snprintf(s, sizeof(s), ", SLAM jitter %.1f cm smoothed", 100.0 * r.jitter.white);
  return s;
}

/// The map's expected error by band of distance from the route, moved as `map` was (none: by
/// the sheet), and rebuilt from its points' poses where it was not.
std::string mapSigmaLine(const GeoreferenceResult& r, const MapInfo* map) {
  const bool own = map != nullptr && !map->pose_field.empty();
  const auto bands = [](const std::array<MapSigmaBand, kMapSigmaBands>& m) {
    char s[128];
    std::snprintf(s, sizeof(s), "%.3f (%.3f) / %.3f (%.3f) / %.3f (%.3f) m", m[0].h_median,
                  m[0].h_p95, m[1].h_median, m[1].h_p95, m[2].h_median, m[2].h_p95);
    return std::string(s);
  };
  std::string line =
      "  map vs truth   sigma per axis, median (95th percentile), 0-10 / 10-30 / 30-50 m from the "
      "route: " +
      bands(own ? r.map_sigma.own_pose : r.map_sigma.sheet) +
      (own ? ", each point with its own pose" : ", warped by the sheet");
  if (!own) line += "; rebuilt from its points' time " + bands(r.map_sigma.own_pose);
  return line + "\n";
}

void printSummary(const GeoreferenceResult& r, const Params& params, const MapInfo* map,
                  const std::string& out, const std::string& map_frame) {
  char line[512];
  std::snprintf(line, sizeof(line),
                "flexcloud: %zu poses (%zu with GNSS), %zu control points, %zu tetrahedra\n",
                r.poses.size(), r.poses_matched, r.control_points.points.size(),
                r.sheet->numTetrahedra());
  std::cout << line;
  if (r.datum) {
    std::snprintf(line, sizeof(line), "  datum          %.9f %.9f %.3f\n", r.datum->lat,
                  r.datum->lon, r.datum->alt);
    std::cout << line;
  }
  std::snprintf(
      line, sizeof(line),
      "  trajectory vs truth  sigma per axis: median %.3f m, 95th percentile %.3f m (the 95 %% "
      "circle: 2.45 sigma); least certain %.3f m at %.1f-%.1f s; %s, rigid "
      "scale %.4f, %s%s, %s\n",
      r.sigma.median_h, r.sigma.p95_h, r.sigma.worst.sigma_h, r.sigma.worst.from, r.sigma.worst.to,
      toString(r.method).c_str(), r.scale, rejectedShare(r).c_str(), jitterPart(r).c_str(),
      clockPart(r).c_str());
  std::cout << line;
  std::cout << mapSigmaLine(r, map);
  const auto& a = r.metrics_aligned;
  const auto& b = r.metrics_rubbersheet;
  std::snprintf(line, sizeof(line),
                "  fit to the GNSS     aligned: MAE %.3f STD %.3f MAX %.3f m | rubber sheet: MAE "
                "%.3f STD %.3f MAX %.3f m\n",
                a.mae, a.std, a.max, b.mae, b.std, b.max);
  std::cout << line;
  if (map != nullptr && map->pose_field == kKeyframeDump) {
    std::snprintf(line, sizeof(line),
                  "  map            %zu points of a keyframe dump rebuilt, each keyframe with its "
                  "own pose (%zu naming none, %zu NaN kept)\n",
                  map->warp.points, map->warp.outside, map->warp.non_finite);
    std::cout << line;
  } else if (map != nullptr && !map->pose_field.empty()) {
    std::snprintf(line, sizeof(line),
                  "  map            %zu points rebuilt, each with its own pose (field '%s'; %zu "
                  "naming none, %zu NaN kept)\n",
                  map->warp.points, map->pose_field.c_str(), map->warp.outside,
                  map->warp.non_finite);
    std::cout << line;
  } else if (map != nullptr) {
    std::snprintf(line, sizeof(line),
                  "  map            %zu points warped (%zu outside the cuboid, %zu NaN kept)\n",
                  map->warp.points, map->warp.outside, map->warp.non_finite);
    std::cout << line;
  }
  if (map != nullptr && map->has_truth) {
    std::snprintf(line, sizeof(line),
                  "  map vs truth   rigid only: RMSE %.3f MAX %.3f m | %s: RMSE %.3f MAX %.3f m\n",
                  map->truth_aligned.rmse, map->truth_aligned.max,
                  map->pose_field.empty() ? "rubber sheet" : "rebuilt", map->truth_rubbersheet.rmse,
                  map->truth_rubbersheet.max);
    std::cout << line;
  }
  for (const auto& w : mapWarnings(r, params, map, map_frame)) {
    std::cout << "  warning        " << w << "\n";
  }
  std::cout << "  outputs in     " << out << "\n";
}

/// "x y z lat lon alt" of map-frame points through the result (the rubber sheet, then WGS84).
std::string pointsLlText(const GeoreferenceResult& r, const std::vector<Eigen::Vector3d>& points) {
  std::string out =
      "# x y z (map frame, m) latitude longitude (deg, WGS84) altitude (m, ellipsoid)\n";
  char line[256];
  for (const auto& p : points) {
    const Datum g = enuToGeodetic(r, mapToEnu(r, p));
    std::snprintf(line, sizeof(line), "%.4f %.4f %.4f %.10f %.10f %.4f\n", p.x(), p.y(), p.z(),
                  g.lat, g.lon, g.alt);
    out += line;
  }
  return out;
}

/// Checks the map's header before the pipeline runs, so a bad map costs nothing: it is then
/// streamed in every encoding (read, warped and written chunk by chunk: memory stays small
/// whatever its size). False when there is no map.
bool checkMap(const Options& o, bool point_sigma, MapInfo& info) {
  if (o.map.empty()) return false;
  const PcdHeader header = readPcdHeader(o.map);
  if (header.points == 0) throw Error(o.map + ": the map holds no points");
  xyzLayout(pclFields(header), header.point_step, header.points, header.points * header.point_step,
            o.map);
  if (point_sigma) withSigmaFields(pclFields(header), header.point_step, o.map);
  info.input = o.map;
  return true;
}

/// Refuses a truth made in another ENU frame than the run's.
void checkTruthFrame(const Options& o, const GeoreferenceResult& r) {
  if (o.truth.empty()) return;
  const Datum& t = *o.truth_datum;
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%.9f %.9f %.4f", t.lat, t.lon, t.alt);
  if (!r.datum) {
    throw Error("--truth: the GNSS came without a datum; give --datum " + std::string(buf));
  }
  const Datum& d = *r.datum;
  if (std::abs(d.lat - t.lat) > 1e-9 || std::abs(d.lon - t.lon) > 1e-9 ||
      std::abs(d.alt - t.alt) > 1e-4) {
    throw Error("--truth " + o.truth + ": the truth is in the ENU frame of the datum " + buf +
                ", this run's datum is another; give --datum " + buf);
  }
}

/// The writer that streams a map (any encoding) through the warp into the output.
/// `map` is the file to read (--map, or the bag's scans gathered into one), `pose_field` the
/// field that names each point's pose (map_pose_field, or the scans' scan_time).
MapWriter streamedMap(const Options& o, const Params& params, const GeoreferenceResult& r,
                      const Progress& log, MapInfo& info, MapPrecopy* precopy,
                      const std::string& map, const std::string& pose_field,
                      const std::string& label) {
  return [&o, &params, &r, &log, &info, precopy, map, pose_field, label](const std::string& path) {
    log.say("warping " + label + " (streamed)");
    MapStreamOptions so;
    so.threads = params.threads;
    so.truth = o.truth;
    so.T_enu_map = r.T_enu_map;
    so.cancel = &g_interrupt;
    so.precopy = precopy;
    const PoseCorrections corrections(r.poses, resultPoses(r), r.T_enu_map);
    so.corrections = &corrections;
    so.pose_field = pose_field;
    std::optional<PointSigmaField> sigmas;
    if (params.point_sigma)
      so.point_sigma = &sigmas.emplace(r.rubbersheet, r.sigma, *r.sheet, pointSigmaModel(params));
    warpPcdFile(map, path, *r.sheet, so, info);
    info.input = label;
  };
}

/// The writer that rebuilds a keyframe dump's map, a keyframe at a time.
MapWriter keyframeMap(const Options& o, const Params& params, const GeoreferenceResult& r,
                      const Progress& log, const std::vector<Keyframe>& keyframes, MapInfo& info) {
  return [&o, &params, &r, &log, &keyframes, &info](const std::string& path) {
    log.say("rebuilding the map of " + o.keyframes);
    const PoseCorrections corrections(r.poses, resultPoses(r), r.T_enu_map);
    std::optional<PointSigmaField> sigmas;
    if (params.point_sigma)
      sigmas.emplace(r.rubbersheet, r.sigma, *r.sheet, pointSigmaModel(params));
    writeKeyframeMap(keyframes, corrections, path, sigmas ? &*sigmas : nullptr, g_interrupt, info);
    info.input = o.keyframes;
  };
}

int run(int argc, char** argv) {
  const Options o = parseOptions(argc, argv);
  const Params params = loadParams(o);
  const Progress log(o.quiet);
  RunContext context;
  // Python and matplotlib load while the drive is georeferenced.
  std::optional<PlotJob> plot;
  if (params.report_png) context.plot = &plot.emplace(findPlotScript());
  const std::vector<Keyframe> keyframes =
      o.keyframes.empty() ? std::vector<Keyframe>() : readKeyframes(o.keyframes);
  BagScans bag_scans;
  const DriveInput drive = loadDrive(o, log, context.frames.map, keyframes, &bag_scans);
  const bool scans = bag_scans.cloud != nullptr;
  checkCancel();
  MapInfo info;
  const bool map_file = checkMap(o, params.point_sigma, info);
  const bool has_map = map_file || !keyframes.empty() || scans;
  checkCancel();
  // A binary map's body starts on its way into the output now, beside the georeferencing.
  // (With point sigmas every point grows: the body is written by the warp.)
  const std::unique_ptr<MapPrecopy> precopy =
      map_file && !params.point_sigma ? MapPrecopy::start(o.map, o.out) : nullptr;

  std::vector<Eigen::Vector3d> to_ll;
  if (!o.to_ll.empty()) to_ll = readPointsFile(o.to_ll);

  log.say("georeferencing");
  const GeoreferenceResult r = georeference(drive, params);
  if (!o.to_ll.empty() && !r.datum) throw Error("--to-ll: the GNSS came without a datum");
  checkTruthFrame(o, r);
  checkDegraded(r, params, nullptr, context.frames.map);  // before the map: it costs nothing
  checkCancel();
  // The scans' map goes through the same streamed warp as a map file, from a temporary copy
  // (scans in the body's frame placed by the SLAM's poses first).
  const TempFile scan_pcd(scans ? "scans" : "");
  if (scans) writeScanMap(bag_scans, r, scan_pcd.path());

  const MapWriter write_map =
      !keyframes.empty() ? keyframeMap(o, params, r, log, keyframes, info)
      : scans ? streamedMap(o, params, r, log, info, nullptr, scan_pcd.path(), kScanTimeField,
                            "the scans on " + o.scan_topic)
      : has_map
          ? streamedMap(o, params, r, log, info, precopy.get(), o.map, params.map_pose_field, o.map)
          : MapWriter();
  checkCancel();
  log.say("writing " + o.out);
  context.map = has_map ? &info : nullptr;
  context.cancel = &g_interrupt;
  // The map is written first, so the peak includes it.
  const MapWriter measured = [&](const std::string& path) {
    if (write_map) write_map(path);
    context.peak_memory_mb = peakMemoryMb();
  };
  context.peak_memory_mb = peakMemoryMb();
  context.measure_peak = [] { return peakMemoryMb(); };
  const ExportSummary exports =
      writeOutputs(o.out, r, params, has_map ? measured : MapWriter(), context);
  for (const auto& note : exports.notes) log.say(note);
  if (!o.to_ll.empty()) writeTextFile(o.out + "/points_ll.txt", pointsLlText(r, to_ll));
  if (has_map) {
    log.say("  map: read " + std::to_string(info.read_seconds) + " s, warp " +
            std::to_string(info.warp_seconds) + " s, write " + std::to_string(info.write_seconds) +
            " s");
  }
  printSummary(r, params, has_map ? &info : nullptr, o.out, context.frames.map);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  flexcloud::keepFreedMemory();
  std::signal(SIGINT, [](int) { g_interrupt.cancel(); });
  std::signal(SIGTERM, [](int) { g_interrupt.cancel(); });
  ros::Time::init();
  try {
    return run(argc, argv);
  } catch (const UsageError& e) {
    std::cerr << "georeference: " << e.what() << " (see --help)" << std::endl;
    return 2;
  } catch (const flexcloud::Error& e) {
    std::cerr << "georeference: " << e.what() << std::endl;
    return g_interrupt.cancelled() ? 130 : 1;
  } catch (const std::exception& e) {
    std::cerr << "georeference: unexpected failure: " << e.what() << std::endl;
    return 1;
  }
}
