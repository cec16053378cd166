#include "flexcloud/params.h"

#include <cmath>

#include "flexcloud/geo/projection.h"
#include "flexcloud/uncertainty/point_sigma.h"
#include "sheet/sheet_builder.h"

namespace flexcloud {

std::string toString(InterpolationMode mode) {
  return mode == InterpolationMode::kSpline ? "spline" : "nearest";
}

InterpolationMode parseInterpolationMode(const std::string& text) {
  if (text == "spline") return InterpolationMode::kSpline;
  if (text == "nearest") return InterpolationMode::kNearest;
  throw Error("interpolation: '" + text + "' is not one of spline, nearest");
}

namespace {

using P = Params;
constexpr double kNaN = Params::kNaN;

ParamRow<P> datumRow(const char* name, double P::*m, double min, double max, const char* unit,
                     const char* doc) {
  ParamRow<P> r = realRow<P>(name, m, kNaN, min, max, unit, doc);
  r.spec.nan_unset = true;
  return r;
}

ParamRow<P> interpolationRow() {
  ParamSpec spec{"interpolation",
                 ParamType::kChoice,
                 {0.0, "spline", {}},
                 0,
                 0,
                 false,
                 {"spline", "nearest"},
                 "",
                 "Keyframe interpolation: cubic through four GNSS points, or the nearest in time",
                 true};
  return {spec,
          [](const P& p) {
            return ParamValue{0.0, toString(p.interpolation), {}};
          },
          [](P& p, const ParamValue& v) { p.interpolation = parseInterpolationMode(v.text); }};
}

ParamTable<P> makeTable() {
  const Live live = Live::kYes;
  return ParamTable<P>({
      datumRow("datum_lat", &P::datum_lat, -90, 90, "deg",
               "Latitude of the ENU datum; unset: the first valid fix is the datum"),
      datumRow("datum_lon", &P::datum_lon, -180, 180, "deg",
               "Longitude of the ENU datum; set with datum_lat and datum_alt"),
      datumRow("datum_alt", &P::datum_alt, -11000, 100000, "m",
               "Ellipsoidal altitude of the ENU datum; set with datum_lat and datum_lon"),
      realRow<P>("default_std_dev", &P::default_std_dev, 0.0, 0.0, 1000, "m",
                 "Std-dev given to fixes whose covariance is unknown; 0: the fusion estimates it "
                 "(with fusion false such fixes are dropped)"),
      realRow<P>("gnss_time_offset", &P::gnss_time_offset, 0.0, -1e10, 1e10, "s",
                 "Added to every GNSS stamp before matching (SLAM clock minus GNSS clock)"),
      realRow<P>("max_gnss_speed", &P::max_gnss_speed, 150.0, 0.1, 10000, "m/s",
                 "A step between fixes faster than this is a jump; the fixes that jumped away "
                 "are dropped"),
      boolRow<P>("fusion", &P::fusion, true,
                 "Fuse SLAM and GNSS robustly before choosing control points (false: the "
                 "published method's GNSS at the poses)",
                 live),
      realRow<P>(
          "fusion_spacing", &P::fusion_spacing, 8.0, 0.1, 1000, "m",
          "Path between the keyframes the fusion estimates (grown to at most 1500 keyframes)"),
      realRow<P>("slam_rotation_noise", &P::slam_rotation_noise, 0.2, 0.001, 100, "deg/sqrt(km)",
                 "Random rotation error of the SLAM, beyond a slowly changing drift rate", live),
      realRow<P>("slam_translation_noise", &P::slam_translation_noise, 0.1, 0.0001, 100,
                 "m/sqrt(km)", "Random translation error of the SLAM", live),
      realRow<P>("slam_drift_noise", &P::slam_drift_noise, 0.5, 0.0001, 1000, "deg/km/sqrt(km)",
                 "How fast the SLAM's rotation drift rate may change along the path", live),
      realRow<P>("slam_scale_noise", &P::slam_scale_noise, 0.05, 0.00001, 100, "%/sqrt(km)",
                 "How fast the SLAM's scale error may change along the path"),
      realRow<P>("gnss_std_floor", &P::gnss_std_floor, 0.01, 0.0001, 100, "m",
                 "Smallest std-dev a fix is weighted with"),
      realRow<P>("outlier_threshold", &P::outlier_threshold, 3.0, 0.5, 100, "sigma",
                 "Scale of the robust loss: fixes far beyond it lose their pull", live),
      realRow<P>("max_time_offset", &P::max_time_offset, 1.0, 0.0, 10, "s",
                 "Largest GNSS clock offset estimated, by the fusion or without it from the speeds "
                 "(0: none)"),
      realRow<P>("max_slam_noise_scale", &P::max_slam_noise_scale, 100.0, 1.0, 10000, "",
                 "Largest factor the fusion raises the slam_*_noise by where the GNSS says the "
                 "SLAM drifts more (1: never)"),
      realRow<P>("lever_arm_x", &P::lever_arm_x, 0.0, -10, 10, "m",
                 "GNSS antenna in the body frame of the poses, forward (x, y, z all 0: the "
                 "fusion estimates the antenna's horizontal offset; the poses stay the antenna's)"),
      realRow<P>("lever_arm_y", &P::lever_arm_y, 0.0, -10, 10, "m",
                 "GNSS antenna in the body frame of the poses, left"),
      realRow<P>("lever_arm_z", &P::lever_arm_z, 0.0, -10, 10, "m",
                 "GNSS antenna in the body frame of the poses, up"),
      boolRow<P>("smooth_jitter", &P::smooth_jitter, true,
                 "Take the SLAM's white jitter from pose to pose out of the trajectories (a "
                 "local cubic over at most 1 s) where its poses show it beyond their motion; the "
                 "map and its sheet are not changed",
                 live),
      interpolationRow(),
      realRow<P>("min_spacing", &P::min_spacing, 1.0, 0.0, 100, "m",
                 "Minimum distance between the GNSS points that support the spline", live),
      realRow<P>("max_gap", &P::max_gap, 1.0, 0.01, 600, "s",
                 "Longest GNSS gap interpolated across; poses in longer gaps get no GNSS", live),
      intRow<P>("control_points", &P::control_points, 200, 4, 100000, "",
                "Number of control points", live),
      realRow<P>("stddev_threshold", &P::stddev_threshold, 0.1, 0.001, 100, "m",
                 "Largest horizontal GNSS std-dev (the larger of east and north) of a fix the "
                 "alignment and the control points take; with the fusion, where it leaves fewer "
                 "than a quarter of the fixes, every fix is weighed by its std-dev instead",
                 live),
      realRow<P>("refine_fraction", &P::refine_fraction, 0.75, 0.0, 1.0, "",
                 "Share of control points placed by error-driven refinement (0: even spread)",
                 live),
      rangesRow<P>("excluded_ranges", &P::excluded_ranges, "s",
                   "Time ranges (SLAM clock) from which no fix and no control point is taken"),
      realRow<P>(
          "beside_distance", &P::beside_distance, 25.0, 0.0, 500, "m",
          "Control points this far left and right of each one on the trajectory, and twice as far "
          "(0: none)",
          live),
      realRow<P>("above_height", &P::above_height, 10.0, 0.0, 500, "m",
                 "A control point this far above each one on the trajectory (0: none)", live),
      realRow<P>("margin_x", &P::margin_x, 0.1, 0.0, 100, "",
                 "Cuboid margin beyond the trajectory, fraction of the x extent", live),
      realRow<P>("margin_y", &P::margin_y, 0.1, 0.0, 100, "",
                 "Cuboid margin beyond the trajectory, fraction of the y extent", live),
      realRow<P>("margin_z", &P::margin_z, 10.0, 0.0, 100, "",
                 "Cuboid margin beyond the trajectory, fraction of the z extent", live),
      realRow<P>("margin_min", &P::margin_min, 20.0, 0.1, 10000, "m",
                 "Smallest cuboid margin on every axis", live),
      realRow<P>("max_uncovered_share", &P::max_uncovered_share, 0.1, 0.0, 1.0, "",
                 "Warn when more than this share of the poses or map points lies outside the "
                 "GNSS coverage"),
      realRow<P>("max_sigma_h", &P::max_sigma_h, 0.5, 0.0, 1000, "m",
                 "Warn where the result may lie further than this from the truth (1-sigma per "
                 "horizontal axis, trajectory_sigma.txt; 0: never)"),
      boolRow<P>(
          "accept_degraded", &P::accept_degraded, false,
          "Keep a result that cannot be right (more than 80 % of the fixes rejected, a rigid "
          "scale 5 % off, most of the map far from every pose), marked degraded in report.json; "
          "false: the run fails naming why",
          live),
      boolRow<P>("autoware", &P::autoware, false,
                 "Also write the map as Autoware takes it: autoware/ with tiles, their metadata "
                 "and map_projector_info.yaml"),
      realRow<P>("tile_size", &P::tile_size, 20.0, 1.0, 100000, "m",
                 "Side of the square Autoware map tiles, whole metres (Autoware reads the "
                 "tiles' corners as integers)"),
      choiceRow<P>("projector", &P::projector, "local_cartesian", projectorNames(),
                   "Frame of the Autoware tiles: local_cartesian (ENU at the datum, no point "
                   "moves), local_cartesian_utm, mgrs"),
      boolRow<P>("las", &P::las, false,
                 "Also write map_georeferenced.las: LAS 1.4 in the datum's UTM zone for GIS tools"),
      textRow<P>("map_pose_field", &P::map_pose_field, "auto",
                 "The map's per-point field that names each point's pose: its points are then "
                 "moved with their own pose's correction, not by the rubber sheet (auto: a "
                 "float64 time, timestamp, gps_time or t on the odometry's clock, or an integer "
                 "scan_index, scan_id, scan or keyframe, the pose's index; none: always the "
                 "sheet)"),
      boolRow<P>("point_sigma", &P::point_sigma, false,
                 "Give every map point the fields sigma_h and sigma_v (float32, m): how far it "
                 "may lie from its true place (a map of 8 more bytes a point)"),
      realRow<P>("point_scatter", &P::point_scatter, 0.02, 0.0, 10, "m",
                 "With point_sigma: the SLAM map's own scatter about its poses, 1-sigma per axis"),
      realRow<P>("point_heading_sigma", &P::point_heading_sigma, 4.0, 0.0, 100, "mrad",
                 "With point_sigma: the map's rotation about the vertical near a pose, 1-sigma "
                 "(moves a point by this times its distance from the pose)"),
      realRow<P>("point_tilt_sigma", &P::point_tilt_sigma, 2.0, 0.0, 100, "mrad",
                 "With point_sigma: the map's roll and pitch near a pose, 1-sigma"),
      boolRow<P>("report_png", &P::report_png, true,
                 "Draw report.png (Python and matplotlib: about 0.6 s of one core per run); "
                 "false leaves it out"),
      intRow<P>("threads", &P::threads, 0, 0, 1024, "", "Threads for the map warp; 0: all cores"),
  });
}

}  // namespace

const ParamTable<Params>& paramTable() {
  static const ParamTable<Params> table = makeTable();
  return table;
}

Params::Params() { paramTable().setDefaults(*this); }

bool Params::hasDatum() const {
  return std::isfinite(datum_lat) && std::isfinite(datum_lon) && std::isfinite(datum_alt);
}

std::string Params::ruleProblems() const {
  std::string out;
  const bool none = std::isnan(datum_lat) && std::isnan(datum_lon) && std::isnan(datum_alt);
  if (!none && !hasDatum()) out = "datum_lat, datum_lon, datum_alt: give all three or none";
  if (std::isfinite(tile_size) && tile_size != std::round(tile_size)) {
    const ParamSpec& spec = paramTable().row("tile_size").spec;
    out += std::string(out.empty() ? "" : "; ") + "tile_size " +
           formatValue(spec, ParamValue{tile_size, "", {}}) +
           " m: Autoware reads the tiles' corners as integers; give whole metres";
  }
  return out;
}

std::string Params::validate() const {
  const std::string ranges = paramTable().validate(*this);
  const std::string rules = ruleProblems();
  return ranges.empty() ? rules : rules.empty() ? ranges : ranges + "; " + rules;
}

GnssOptions gnssOptions(const Params& p) {
  GnssOptions o;
  if (p.hasDatum()) o.datum = Datum{p.datum_lat, p.datum_lon, p.datum_alt};
  o.default_std_dev = p.default_std_dev;
  // The fusion estimates missing std-devs and judges every fix against the SLAM and the other
  // fixes; a jump filter on the GNSS alone keeps the wrong side after an isolated outlier, so it
  // only runs without the fusion.
  o.estimate_unknown_std = p.fusion;
  o.drop_jumps = !p.fusion;
  o.time_offset = p.gnss_time_offset;
  o.max_speed = p.max_gnss_speed;
  return o;
}

FusionOptions fusionOptions(const Params& p) {
  FusionOptions o;
  o.keyframe_spacing = p.fusion_spacing;
  o.slam_rotation_noise = p.slam_rotation_noise;
  o.slam_translation_noise = p.slam_translation_noise;
  o.slam_drift_noise = p.slam_drift_noise;
  o.slam_scale_noise = p.slam_scale_noise;
  o.gnss_std_floor = p.gnss_std_floor;
  o.outlier_threshold = p.outlier_threshold;
  o.max_time_offset = p.max_time_offset;
  o.max_slam_noise_scale = p.max_slam_noise_scale;
  o.lever_arm = Eigen::Vector3d(p.lever_arm_x, p.lever_arm_y, p.lever_arm_z);
  o.stddev_threshold = p.stddev_threshold;
  o.excluded_ranges = p.excluded_ranges;
  o.threads = p.threads;
  return o;
}

InterpolationOptions interpolationOptions(const Params& p) {
  return InterpolationOptions{p.interpolation, p.min_spacing, p.max_gap};
}

PointSigmaModel pointSigmaModel(const Params& p) {
  PointSigmaModel m;
  m.scatter_h = m.scatter_v = p.point_scatter;
  m.heading = p.point_heading_sigma * 1e-3;
  m.tilt = p.point_tilt_sigma * 1e-3;
  return m;
}

ControlPointOptions controlPointOptions(const Params& p) {
  return ControlPointOptions{p.control_points, p.stddev_threshold, p.excluded_ranges};
}

SheetOptions sheetOptions(const Params& p) {
  SheetOptions o;
  o.control_points = controlPointOptions(p);
  o.refine_fraction = p.refine_fraction;
  o.beside_distance = p.beside_distance;
  o.above_height = p.above_height;
  o.margin = Eigen::Vector3d(p.margin_x, p.margin_y, p.margin_z);
  o.margin_min = p.margin_min;
  return o;
}

}  // namespace flexcloud
