#include "flexcloud/io/outputs.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "flexcloud/io/atomic_file.h"
#include "flexcloud/io/geojson.h"
#include "flexcloud/io/report_plot.h"
#include "flexcloud/io/text_io.h"
#include "staging.h"

namespace flexcloud {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

json stats(const ErrorStats& s) {
  return {{"mae", s.mae}, {"std", s.std}, {"max", s.max}, {"rmse", s.rmse}, {"count", s.count}};
}

json paramsJson(const Params& params) {
  json j;
  for (const auto& row : paramTable().rows()) {
    const ParamValue v = row.get(params);
    json& out = j[row.spec.name];
    switch (row.spec.type) {
      case ParamType::kReal:
        out = std::isfinite(v.number) ? json(v.number) : json(nullptr);
        break;
      case ParamType::kInt:
        out = static_cast<long long>(v.number);
        break;
      case ParamType::kBool:
        out = v.number != 0.0;
        break;
      case ParamType::kText:
      case ParamType::kChoice:
        out = v.text;
        break;
      case ParamType::kRanges:
        out = json::array();
        for (const auto& r : v.ranges) out.push_back({r.begin, r.end});
        break;
    }
  }
  return j;
}

json finiteOrNull(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

/// The stretches where precise fixes were followed against the SLAM's shape.
json slamFailuresJson(const std::vector<FusionResult::SlamFailure>& runs) {
  json out = json::array();
  for (const auto& run : runs) {
    out.push_back({{"from_s", run.begin},
                   {"to_s", run.end},
                   {"fixes", run.fixes},
                   {"slam_off_by_m", run.worst},
                   {"precision_m", run.precision},
                   {"std_dev_given", run.claimed}});
  }
  return out;
}

/// How many poses the refinement by precise fixes turned in heading, and the largest turn.
json headingsTurnedJson(const std::vector<double>& turn) {
  std::size_t poses = 0;
  double largest = 0.0;
  for (double t : turn) {
    poses += t != 0.0;
    largest = std::max(largest, std::abs(t));
  }
  return {{"poses", poses}, {"largest_deg", largest * 180.0 / M_PI}};
}

json fusionJson(const FusionResult& f) {
  return {{"keyframes", f.keyframes},
          {"fixes_used", f.used},
          {"fixes_used_without_height", f.heights_left_out},
          {"fixes_rejected",
           {{"outlier", f.outliers},
            {"above_std_threshold", f.above_threshold},
            {"excluded_range", f.excluded},
            {"outside_poses", f.outside}}},
          {"time_offset_s", f.time_offset},
          {"time_offset_estimated", f.time_offset_estimated},
          {"time_offset_sigma_s", finiteOrNull(f.time_offset_sigma)},
          {"lever_arm_m", {f.lever_arm.x(), f.lever_arm.y(), f.lever_arm.z()}},
          {"antenna_offset_estimated", f.antenna_offset_estimated},
          {"antenna_offset_m",
           f.antenna_offset_estimated ? json{f.antenna_offset.x(), f.antenna_offset.y()} : json()},
          {"estimated_std_h_m", finiteOrNull(f.estimated_std_h)},
          {"estimated_std_v_m", finiteOrNull(f.estimated_std_v)},
          {"median_std_h_m", f.median_std_h},
          {"slam_noise_scale", f.slam_noise_scale},
          {"gnss_roughness_h_m", f.gnss_roughness_h},
          {"slam_jitter_h_m", f.slam_jitter_h},
          {"slam_jitter_v_m", f.slam_jitter_v},
          {"poses_moved_to_fixes", f.detail_poses},
          {"largest_move_to_fixes_m", f.detail_max_shift},
          {"precise_fixes",
           {{"fixes", f.follow.fixes},
            {"slam_short_term_q_h_m2_per_m", f.follow.q_h},
            {"slam_short_term_q_v_m2_per_m", f.follow.q_v},
            {"slam_excess_m", f.follow.excess},
            {"slam_jumps", f.follow.jumps},
            {"taken_back", f.follow.taken_back},
            {"kept_out_too_far", f.follow.locked},
            {"rejected", f.follow.rejected},
            {"slam_failures_followed", slamFailuresJson(f.follow.slam_failures)},
            {"headings_turned", headingsTurnedJson(f.heading_turn)}}},
          {"drive_ends_followed", slamFailuresJson(f.drive_ends_followed)},
          {"stages", f.stages},
          {"solves", f.solves},
          {"seconds", f.seconds}};
}

/// How far the result may lie from the truth (pose_sigma.h).
json sigmaJson(const PoseSigmas& s) {
  return {
      {"file", "trajectory_sigma.txt"},
      {"sigma_h_median_m", finiteOrNull(s.median_h)},
      {"sigma_h_p95_m", finiteOrNull(s.p95_h)},
      {"sigma_v_median_m", finiteOrNull(s.median_v)},
      {"worst_stretch",
       {{"from", s.worst.from}, {"to", s.worst.to}, {"sigma_h_m", finiteOrNull(s.worst.sigma_h)}}},
      {"fixes", s.fixes},
      {"walk_h_m2_per_m", s.walk_h},
      {"walk_v_m2_per_m", s.walk_v}};
}

/// The map's expected error by band of distance from the route.
json mapBandsJson(const std::array<MapSigmaBand, kMapSigmaBands>& bands) {
  json out = json::array();
  for (int b = 0; b < kMapSigmaBands; ++b) {
    out.push_back({{"from_m", kMapSigmaBandEdges[b]},
                   {"to_m", kMapSigmaBandEdges[b + 1]},
                   {"sigma_h_rms_m", finiteOrNull(bands[b].h_rms)},
                   {"sigma_h_median_m", finiteOrNull(bands[b].h_median)},
                   {"sigma_h_p95_m", finiteOrNull(bands[b].h_p95)},
                   {"sigma_v_rms_m", finiteOrNull(bands[b].v_rms)}});
  }
  return out;
}

/// How far the map may lie from the truth: moved as this run moved it (a plain map, or none,
/// by the sheet), and as a map whose points name their pose would be.
json mapSigmaJson(const MapSigma& m, bool own_pose) {
  return {{"moved_by", own_pose ? "own_pose" : "rubber_sheet"},
          {"bands", mapBandsJson(own_pose ? m.own_pose : m.sheet)},
          {"bands_if_rebuilt", mapBandsJson(m.own_pose)},
          {"points", "at the sensor's height beside every pose, 1-sigma per axis"}};
}

/// The clocks: what the trajectories are stamped with, and the offset to the GNSS's.
json clockJson(const GeoreferenceResult& r, const Params& params) {
  json j = {{"trajectories", "SLAM clock (the poses' own stamps)"},
            {"offset_s", r.clock_offset},
            {"offset_sigma_s", finiteOrNull(r.clock_offset_sigma)},
            {"gnss_clock", "stamp - offset_s: *_gnss_clock.txt"}};
  if (r.fusion) {
    j["estimated"] = r.fusion->time_offset_estimated;
    j["from_speed_profiles_s"] = r.fusion->time_offset_from_speed;
    j["from_speed_profiles_sigma_s"] = finiteOrNull(r.fusion->time_offset_speed_sigma);
    const ClockEstimate& c = r.fusion->clock;
    j["from_heading_profiles_s"] = finiteOrNull(c.heading.observable ? c.heading.offset : NAN);
    j["from_heading_profiles_sigma_s"] = finiteOrNull(c.heading.sigma);
    j["from_profiles_s"] = c.offset;
    j["from_profiles_sigma_s"] = finiteOrNull(c.sigma);
    j["profiles_disagree"] = c.disagree;
    if (!c.reason.empty()) j["why_not_estimated"] = c.reason;
    j["from_positions_s"] = r.fusion->time_offset_from_positions;
    j["decided_by_positions"] = c.loose;
    j["held_at_speed_profiles"] = r.fusion->time_offset_held;
  } else if (r.speed_clock) {
    j["estimated"] = std::isfinite(r.clock_offset_sigma);  // shown beyond its noise: applied
    j["from_speed_profiles_s"] = r.speed_clock->offset;
    j["from_speed_profiles_sigma_s"] = finiteOrNull(r.speed_clock->sigma);
    if (!j["estimated"].get<bool>()) {
      j["why_not_estimated"] = r.speed_clock->observable ? "within three of its sigmas of 0"
                                                         : "the speed varies too little to show it";
    }
  } else {
    j["estimated"] = false;
  }
  if (!(params.max_time_offset > 0.0)) {
    j["why_not_estimated"] = "max_time_offset is 0: no offset asked for (gnss_time_offset applied)";
  }
  return j;
}

json exportsJson(const ExportSummary& e) {
  json j;
  j["trajectories_geojson"] = e.geojson;
  j["report_png"] = e.plot;
  if (e.autoware) {
    j["autoware"] = {{"tiles", e.autoware->tiles},
                     {"points", e.autoware->points},
                     {"points_non_finite_left_out", e.autoware->non_finite},
                     {"mgrs_grid", e.autoware->mgrs_grid}};
  }
  if (e.las) {
    j["las"] = {{"points", e.las->points},
                {"points_non_finite_left_out", e.las->non_finite},
                {"epsg", e.las->epsg},
                {"point_format", e.las->point_format},
                {"extra_fields", e.las->extra_fields}};
  }
  j["skipped"] = e.notes;
  j["seconds"] = e.seconds;
  return j;
}

constexpr const char* kMapFile = "map_georeferenced.pcd";

/// Every output a run may write: those of an earlier run into the same folder that this run
/// does not write are removed when it commits.
const std::vector<std::string> kOutputNames = {kMapFile,
                                               "map_georeferenced.las",
                                               "autoware",
                                               "trajectory_gnss.txt",
                                               "trajectory_slam.txt",
                                               "trajectory_aligned.txt",
                                               "trajectory_rubbersheet.txt",
                                               "trajectory_rubbersheet_gnss_clock.txt",
                                               "trajectory_sigma.txt",
                                               "trajectory_fused.txt",
                                               "trajectory_fused_gnss_clock.txt",
                                               "control_points.txt",
                                               "gnss_fixes.txt",
                                               "origin.yaml",
                                               "trajectories.geojson",
                                               "report.png",
                                               "report.json"};

/// The text files every run writes.
void writeRunFiles(Staging& stage, const GeoreferenceResult& r, const RunContext& run,
                   ExportSummary& e) {
  writeTextFile(stage.path("trajectory_gnss.txt"), gnssTum(r));
  writeTextFile(stage.path("trajectory_slam.txt"), tumText(r.poses, r, false));
  writeTextFile(stage.path("trajectory_aligned.txt"), tumText(r.aligned, r, false));
  writeTextFile(stage.path("trajectory_rubbersheet.txt"), tumText(r.rubbersheet, r, false));
  writeTextFile(stage.path("trajectory_rubbersheet_gnss_clock.txt"),
                tumText(r.rubbersheet, r, true));
  writeTextFile(stage.path("trajectory_sigma.txt"), sigmaText(r));
  writeTextFile(stage.path("control_points.txt"), controlPointsText(r));
  if (r.fusion) {
    writeTextFile(stage.path("trajectory_fused.txt"), tumText(r.fusion->poses, r, false));
    writeTextFile(stage.path("trajectory_fused_gnss_clock.txt"), tumText(r.fusion->poses, r, true));
    writeTextFile(stage.path("gnss_fixes.txt"), fixesText(r));
  }
  writeTextFile(stage.path("origin.yaml"), originYaml(r, run.frames));
  if (r.datum) {
    writeTextFile(stage.path("trajectories.geojson"), trajectoriesGeojson(r));
    e.geojson = true;
  } else {
    e.notes.push_back("trajectories.geojson skipped: the GNSS came without a datum");
  }
}

/// Runs an export of the staged map; its errors name the input map (the staging folder they
/// would name is gone once the run fails).
template <typename F>
auto asInputMap(const std::string& staged, const RunContext& run, F&& f) {
  try {
    return f();
  } catch (const Error& error) {
    const std::string input = run.map->input + " (warped)";
    std::string m = error.what();
    const auto at = m.find(staged);
    if (at == std::string::npos) throw Error(input + ": " + m);
    m.replace(at, staged.size(), input);
    throw Error(m);
  }
}

/// autoware/ and the LAS, made from the staged map.
void writeMapExports(Staging& stage, const GeoreferenceResult& r, const Params& params,
                     const RunContext& run, ExportSummary& e) {
  if (!params.autoware && !params.las) return;
  if (run.map == nullptr) {
    e.notes.push_back("autoware/ and map_georeferenced.las skipped: no map was given");
    return;
  }
  const std::string map = (fs::path(stage.folder()) / kMapFile).string();
  if (params.autoware) {
    AutowareOptions o;
    o.tile_size = params.tile_size;
    o.projector = parseProjector(params.projector);
    o.threads = params.threads;
    o.cancel = run.cancel;
    const std::string dir = stage.path("autoware");
    e.autoware = asInputMap(map, run, [&] { return writeAutowareMap(map, dir, *r.datum, o); });
  }
  if (params.las) {
    const std::string las = stage.path("map_georeferenced.las");
    e.las = asInputMap(map, run,
                       [&] { return writeLas(map, las, *r.datum, params.threads, *run.cancel); });
  }
}

}  // namespace

std::vector<std::string> mapWarnings(const GeoreferenceResult& r, const Params& params,
                                     const MapInfo* map, const std::string& map_frame) {
  if (map == nullptr) return resultWarnings(r, params, nullptr, map_frame);
  if (map->pose_field.empty()) {
    std::vector<std::string> out = resultWarnings(r, params, &map->warp, map_frame);
    if (!map->pose_field_note.empty()) out.push_back(map->pose_field_note);
    return out;
  }
  WarpStats named = map->warp;  // its points outside named no pose: counted here, not there
  named.outside = 0;
  std::vector<std::string> out = resultWarnings(r, params, &named, map_frame);
  const std::size_t finite = map->warp.points - map->warp.non_finite;
  const double share = finite == 0 ? 0.0 : static_cast<double>(map->warp.outside) / finite;
  if (share > params.max_uncovered_share) {
    out.push_back(std::to_string(std::lround(100.0 * share)) + " % of the map points name no " +
                  "pose in their field '" + map->pose_field + "' (none, or beyond the " +
                  "trajectory's ends by more than 1 s): they got the rigid transform only");
  }
  return out;
}

std::string reportJson(const GeoreferenceResult& r, const Params& params, const RunContext& run,
                       const ExportSummary* exports) {
  const MapInfo* map = run.map;
  const FrameNames& frames = run.frames;
  json j;
  j["tool"] = "flexcloud";
  j["frames"] = {{"enu", frames.enu}, {"map", frames.map}};
  j["datum"] = r.datum ? json{{"lat", r.datum->lat}, {"lon", r.datum->lon}, {"alt", r.datum->alt}}
                       : json(nullptr);
  json t = json::array();
  const Eigen::Matrix4d m = r.T_enu_map.matrix();
  for (int i = 0; i < 4; ++i) t.push_back({m(i, 0), m(i, 1), m(i, 2), m(i, 3)});
  j["T_enu_map"] = t;
  j["scale"] = r.scale;
  const auto& gd = r.gnss.dropped;
  const auto& cp = r.control_points;
  json counts = {
      {"fixes_received", r.gnss.received},
      {"fixes_used", r.gnss.points.size()},
      {"fixes_dropped", gd.total()},
      {"fixes_dropped_by_reason",
       {{"no_fix", gd.no_fix},
        {"invalid", gd.invalid},
        {"unknown_covariance", gd.unknown_covariance},
        {"duplicate", gd.duplicate},
        {"jump", gd.outlier}}},
      {"poses_received", r.pose_counts.received},
      {"poses", r.poses.size()},
      {"poses_dropped",
       {{"invalid", r.pose_counts.invalid}, {"duplicate", r.pose_counts.duplicate}}},
      {"poses_normalised", r.pose_counts.normalised},
      {"poses_reordered", r.pose_counts.reordered},
      {"poses_matched", r.poses_matched},
      {"control_points", cp.points.size()},
      {"control_points_requested", cp.requested},
      {"control_points_replaced", cp.replaced},
      {"control_points_skipped", cp.skipped},
      {"control_points_merged", cp.merged + (r.sheet ? r.sheet->merged() : 0)},
      {"control_points_added_to_follow_the_fused_trajectory", cp.added},
      {"tetrahedra", r.sheet ? r.sheet->numTetrahedra() : 0},
      {"tetrahedra_degenerate", r.sheet ? r.sheet->degenerate() : 0},
      {"map_points", map ? map->warp.points : 0},
      {"points_outside", map ? map->warp.outside : 0},
      {"points_non_finite", map ? map->warp.non_finite : 0},
  };
  j["counts"] = counts;
  j["revisits"] = {{"pairs", r.revisits.pairs},
                   {"conflicting_slam_at_fault", r.revisits.conflicting},
                   {"worst_m", r.revisits.worst},
                   {"gnss_outvoted", r.revisits.gnss_conflicting}};
  j["metrics"] = {{"aligned", stats(r.metrics_aligned)},
                  {"rubbersheet", stats(r.metrics_rubbersheet)}};
  j["method"] = toString(r.method);
  j["uncertainty"] = sigmaJson(r.sigma);
  j["uncertainty"]["max_sigma_h_m"] = params.max_sigma_h;
  j["uncertainty"]["map"] = mapSigmaJson(r.map_sigma, map && !map->pose_field.empty());
  j["uncertainty"]["beyond_max_sigma_h"] =
      params.max_sigma_h > 0.0 && r.sigma.worst.sigma_h > params.max_sigma_h;
  j["clock"] = clockJson(r, params);
  j["slam_jitter"] = {{"smoothed", r.jitter.half_width > 0},
                      {"white_m", r.jitter.white},
                      {"motion_m", r.jitter.motion},
                      {"own_share", r.jitter.own_share},
                      {"half_width_poses", r.jitter.half_width}};
  if (r.fusion) {
    if (r.method == Method::kFusion) j["metrics"]["rubbersheet_vs_fused"] = stats(r.metrics_fused);
    j["fusion"] = fusionJson(*r.fusion);
  }
  j["beside_points"] = {{"used", r.beside.size()}, {"left_out_folding", r.beside_folding}};
  if (map != nullptr) {
    j["map_moved_by"] = map->pose_field.empty() ? "rubber_sheet" : "own_pose";
    j["map_pose_field"] = map->pose_field;
  }
  j["warnings"] = mapWarnings(r, params, map, run.frames.map);
  const std::vector<std::string> degraded =
      degradedReasons(r, map ? &map->warp : nullptr, run.frames.map);
  j["degraded"] = !degraded.empty();  // kept only where accept_degraded is true
  j["degraded_reasons"] = degraded;
  if (map != nullptr && map->has_truth) {
    j["map_vs_truth"] = {{"aligned", stats(map->truth_aligned)},
                         {"rubbersheet", stats(map->truth_rubbersheet)}};
  }
  if (exports != nullptr) j["exports"] = exportsJson(*exports);
  j["params"] = paramsJson(params);
  const auto& s = r.seconds;
  j["seconds"] = {{"gnss", s.gnss},
                  {"interpolation", s.interpolation},
                  {"alignment", s.alignment},
                  {"control_points", s.control_points},
                  {"fusion", s.fusion},
                  {"trajectory_warp", s.trajectory_warp},
                  {"sigma", s.sigma},
                  {"map_read", map ? map->read_seconds : 0.0},
                  {"map_location_grid", map ? map->grid_seconds : 0.0},
                  {"map_warp", map ? map->warp_seconds : 0.0},
                  {"map_write", map ? map->write_seconds : 0.0}};
  j["peak_memory_mb"] = run.peak_memory_mb >= 0.0 ? json(run.peak_memory_mb) : json(nullptr);
  return j.dump(2) + "\n";
}

std::string originYaml(const GeoreferenceResult& r, const FrameNames& frames) {
  std::ostringstream s;
  s << std::setprecision(12);
  s << "# The frame of map_georeferenced.pcd: local East-North-Up (x east, y north, z up, "
       "metres),\n"
       "# tangent to the WGS84 ellipsoid at the datum (GeographicLib LocalCartesian).\n";
  s << "frame: " << frames.enu << "\n";
  if (r.datum) {
    s << "datum:\n  latitude: " << r.datum->lat
      << "    # degrees, WGS84\n  longitude: " << r.datum->lon
      << "    # degrees, WGS84\n  altitude: " << r.datum->alt
      << "    # metres above the WGS84 ellipsoid\n";
  } else {
    s << "datum: null    # the GNSS came in local coordinates without a datum\n";
  }
  s << "# Rigid part of the georeferencing: p_" << frames.enu << " = T_enu_map * p_" << frames.map
    << " (row-major 4x4);\n# the rubber sheet adds the drift correction on top.\n";
  s << "map_frame: " << frames.map << "\nT_enu_map: [";
  const Eigen::Matrix4d m = r.T_enu_map.matrix();
  for (int i = 0; i < 16; ++i) s << (i ? ", " : "") << m(i / 4, i % 4);
  s << "]\nscale: " << r.scale << "\n";
  return s.str();
}

std::string controlPointsText(const GeoreferenceResult& r) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(6);
  s << "# pose_index stamp source_x source_y source_z (map) target_x target_y target_z (enu) "
       "std_dev residual_aligned residual_rubbersheet\n";
  const auto& cps = r.control_points.points;
  for (std::size_t i = 0; i < cps.size(); ++i) {
    const auto& c = cps[i];
    s << c.pose_index << ' ' << std::setprecision(9) << c.stamp << std::setprecision(6) << ' '
      << c.source.x() << ' ' << c.source.y() << ' ' << c.source.z() << ' ' << c.target.x() << ' '
      << c.target.y() << ' ' << c.target.z() << ' ' << c.std_dev << ' ' << r.residual_aligned[i]
      << ' ' << r.residual_rubbersheet[i] << '\n';
  }
  return s.str();
}

std::string sigmaText(const GeoreferenceResult& r) {
  std::string text =
      "# how far each pose of trajectory_rubbersheet.txt may lie from the truth: stamp (SLAM "
      "clock, as there) sigma_h_m (1-sigma per horizontal axis; 95 % within 2.45 of it) "
      "sigma_v_m (1-sigma vertical; 95 % within 1.96 of it)\n";
  char line[96];
  for (std::size_t i = 0; i < r.rubbersheet.size() && i < r.sigma.h.size(); ++i) {
    std::snprintf(line, sizeof(line), "%.9f %.4f %.4f\n", r.rubbersheet[i].stamp, r.sigma.h[i],
                  r.sigma.v[i]);
    text += line;
  }
  return text;
}

std::string gnssTum(const GeoreferenceResult& r) { return tumText(gnssTrajectory(r), r, false); }

std::string tumText(Trajectory poses, const GeoreferenceResult& r, bool gnss_clock) {
  char head[200];
  if (gnss_clock) {
    for (auto& p : poses) p.stamp -= r.clock_offset;
    std::snprintf(head, sizeof(head),
                  "# TUM: stamp x y z qx qy qz qw; stamps on the GNSS clock (the SLAM's "
                  "minus %.6f s)\n",
                  r.clock_offset);
  } else {
    std::snprintf(head, sizeof(head),
                  "# TUM: stamp x y z qx qy qz qw; stamps on the SLAM clock (the GNSS's plus "
                  "%.6f s)\n",
                  r.clock_offset);
  }
  return head + formatTum(poses);
}

std::string fixesText(const GeoreferenceResult& r) {
  std::string text =
      "# every GNSS fix the fusion judged: stamp (GNSS clock) x y z (enu) residual_m weight "
      "verdict (used, outlier, above_std_threshold, excluded_range, outside_poses) std_h_m "
      "std_v_m (its own: reported, or estimated where not given) slam_jitter_h_m "
      "slam_jitter_v_m slam_gap_m (the SLAM's at its stamp, added to its std-dev in the fusion) "
      "std_source (given: with the fix or by default_std_dev; estimated: by the fusion; none: "
      "took no part and gave none)\n";
  if (!r.fusion) return text;
  text.reserve(text.size() + r.fusion->fixes.size() * 122);
  const auto field = [&text](double v, int decimals) {
    text += ' ';
    appendFixed(text, v, decimals);
  };
  for (const auto& o : r.fusion->fixes) {
    appendFixed(text, o.stamp, 6);
    for (const double v : {o.position.x(), o.position.y(), o.position.z(), o.residual}) field(v, 4);
    field(o.weight, 3);
    text += ' ';
    text += toString(o.verdict);
    for (const double v :
         {o.std_dev.x(), o.std_dev.z(), o.slam_jitter.x(), o.slam_jitter.z(), o.slam_gap}) {
      field(v, 4);
    }
    text += o.std_given ? " given\n" : o.std_dev.allFinite() ? " estimated\n" : " none\n";
  }
  return text;
}

void checkExports(const GeoreferenceResult& r, const Params& params) {
  const ProjectorType projector = parseProjector(params.projector);
  if ((params.autoware || params.las) && !r.datum) {
    throw Error(std::string(params.autoware ? "autoware" : "las") +
                ": needs a datum, and the GNSS came in local coordinates without one");
  }
  if (params.las) utmZoneOf(*r.datum);
  if (params.autoware && projector != ProjectorType::kLocalCartesian)
    MapProjection(*r.datum, projector);
}

namespace {

/// Waits for report.png: kept among the outputs, or a note saying why there is none.
void finishPlot(Staging& stage, PlotJob& plot, ExportSummary& e) {
  const std::string skipped = plot.finish();
  e.plot = skipped.empty();
  if (e.plot) {
    stage.path("report.png");
  } else {
    e.notes.push_back(skipped);
  }
}

/// writeStaged once the picture is being drawn.
ExportSummary writeDrawing(Staging& stage, const std::string& dir, const GeoreferenceResult& r,
                           const Params& params, const MapWriter& write_map, const RunContext& run,
                           PlotJob* plot, ExportSummary e) {
  if (write_map) write_map(stage.path(kMapFile));
  checkDegraded(r, params, run.map ? &run.map->warp : nullptr, run.frames.map);
  const auto t0 = std::chrono::steady_clock::now();
  writeMapExports(stage, r, params, run, e);
  e.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.cancel->check(dir + ": before the outputs were moved into place");
  if (plot != nullptr) finishPlot(stage, *plot, e);
  RunContext measured = run;
  if (run.measure_peak) measured.peak_memory_mb = run.measure_peak();
  writeTextFile(stage.path("report.json"), reportJson(r, params, measured, &e));
  run.cancel->check(dir + ": before the outputs were moved into place");
  stage.commit("report.json", kOutputNames);
  return e;
}

/// writeOutputs once the staging folder exists.
ExportSummary writeStaged(Staging& stage, const std::string& dir, const GeoreferenceResult& r,
                          const Params& params, const MapWriter& write_map, const RunContext& run) {
  ExportSummary e;
  writeRunFiles(stage, r, run, e);
  // The picture needs only the run's files: drawn while the map is warped and written.
  std::optional<PlotJob> own;
  PlotJob* plot = nullptr;
  if (params.report_png) plot = run.plot != nullptr ? run.plot : &own.emplace(run.plot_script);
  if (plot != nullptr) plot->draw(stage.folder());
  try {
    return writeDrawing(stage, dir, r, params, write_map, run, plot, std::move(e));
  } catch (...) {
    // A script still drawing would leave report.png in the staging folder as it goes.
    if (plot != nullptr) plot->stop();
    throw;
  }
}

}  // namespace

ExportSummary writeOutputs(const std::string& dir, const GeoreferenceResult& r,
                           const Params& params, const MapWriter& write_map,
                           const RunContext& run) {
  checkExports(r, params);
  Staging stage(dir);
  try {
    return writeStaged(stage, dir, r, params, write_map, run);
  } catch (const Error& error) {
    throw Error(stage.userMessage(error.what()));
  }
}

}  // namespace flexcloud
