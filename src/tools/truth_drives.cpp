#include "truth_drives.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "flexcloud/input/trajectory.h"
#include "flexcloud/io/text_io.h"
#include "flexcloud/metrics.h"
#include "flexcloud/param_table.h"
#include "flexcloud/params.h"
#include "flexcloud/sim/truth_metrics.h"

namespace flexcloud::study {
namespace {

constexpr double kEnds = 20.0;   // s at either end of the drive
constexpr double kFarFix = 3.0;  // m from the truth: a fix to be rejected
constexpr double kSameStamp = 1e-6;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string need(const std::string& dir, const std::string& name) {
  const std::string path = dir + "/" + name;
  if (!std::filesystem::exists(path)) throw Error("truth drive: " + path + " does not exist");
  return path;
}

/// The truth at a fix's stamp: the truth shares the GNSS's instants (GNSS stamps on the truth's
/// clock), one pose each; none where no pose has that stamp.
const Pose* truthAt(const TruthDrive& d, double stamp) {
  const double t = stamp + d.shift;
  const auto it = std::lower_bound(d.truth.begin(), d.truth.end(), t - kSameStamp,
                                   [](const Pose& p, double s) { return p.stamp < s; });
  if (it == d.truth.end() || std::abs(it->stamp - t) > kSameStamp) return nullptr;
  return &*it;
}

}  // namespace

double knownLag(const std::string& dir) {
  // ../shared/data/mulran_lo/README.md: truth time - stamp, from the odometry's speed profile
  // against the truth's.
  static const std::pair<const char*, double> kMulran[] = {
      {"DCC_02", 0.046},    {"DCC_03", -0.054},       {"KAIST_02", -0.056},
      {"KAIST_03", -0.058}, {"Riverside_02", -0.048}, {"Riverside_03", -0.038}};
  const std::filesystem::path path(dir);
  const std::string seq = path.filename().string();
  if (path.parent_path().filename() != "mulran_lo") return 0.0;
  for (const auto& [name, lag] : kMulran) {
    if (seq == name) return lag;
  }
  return 0.0;
}

Eigen::Vector3d knownMount(const std::string& dir) {
  // The median, axis by axis, of the rotation fitted to each of the six drives with RTK GNSS
  // (TruthScore::fitted_mount): 1.34-1.76 degrees each, -1.33 to -1.55 about y (the LiDAR
  // pitched on the base), 0.08-0.17 about z, -0.02 to 0.84 about x (KAIST_03's odometry rolls).
  const std::filesystem::path path(dir);
  if (path.parent_path().filename() != "mulran_lo") return Eigen::Vector3d::Zero();
  return {0.29, -1.41, 0.10};
}

Eigen::Matrix3d mountRotation(const TruthDrive& d) {
  if (d.mount.isZero()) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(d.mount.norm() * M_PI / 180.0, d.mount.normalized()).toRotationMatrix();
}

TruthDrive loadTruthDrive(const std::string& dir, const std::string& kind, double shift) {
  TruthDrive d;
  d.name = std::filesystem::path(dir).filename().string() + " " + kind;
  d.input.poses = readTumFile(need(dir, "poses_tum.txt"));
  d.input.local_gnss = readLocalGnssFile(need(dir, "gnss_" + kind + ".txt"));
  d.truth = readTumFile(need(dir, "gt_tum.txt"));
  if (d.truth.size() != d.input.poses.size()) {
    throw Error("truth drive: " + dir + ": " + std::to_string(d.input.poses.size()) +
                " poses but " + std::to_string(d.truth.size()) +
                " rows of truth; row i of one file must belong to row i of the other");
  }
  for (auto& p : d.input.poses) p.stamp += shift;
  for (auto& p : d.truth) p.stamp += shift;
  d.shift = shift;
  d.lag = knownLag(dir);
  d.mount = knownMount(dir);
  for (const Pose& p : d.input.poses) {
    Pose t = poseAt(d.truth, p.stamp + d.lag).value_or(Pose{});
    t.stamp = p.stamp;
    if (!poseAt(d.truth, p.stamp + d.lag)) t.position.setConstant(kNaN);
    d.truth_at_pose.push_back(t);
  }
  return d;
}

namespace {

double p95(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(0.95 * static_cast<double>(v.size() - 1))];
}

/// The rotation nearest to `m` (its polar factor).
Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  fix(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * fix * svd.matrixV().transpose();
}

Eigen::Vector3d degrees(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd a(rotation);
  return a.axis() * a.angle() * 180.0 / M_PI;
}

/// The sheet's orientations against the truth (TruthScore's turn_* and mount).
void scoreOrientations(const TruthDrive& d, const GeoreferenceResult& r, TruthScore& s) {
  std::vector<Eigen::Matrix3d> body;  // truth^-1 * result: the error in the truth's body
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < d.truth_at_pose.size() && i < r.rubbersheet.size(); ++i) {
    if (!d.truth_at_pose[i].position.allFinite()) continue;
    body.push_back((d.truth_at_pose[i].orientation.conjugate() * r.rubbersheet[i].orientation)
                       .normalized()
                       .toRotationMatrix());
    sum += body.back();
  }
  if (body.empty()) return;
  const Eigen::Matrix3d mount = mountRotation(d);
  std::vector<double> all, less, axis[3];
  for (const Eigen::Matrix3d& e : body) {
    all.push_back(Eigen::AngleAxisd(e).angle() * 180.0 / M_PI);
    const Eigen::Vector3d left = degrees(mount.transpose() * e);
    less.push_back(left.norm());
    for (int a = 0; a < 3; ++a) axis[a].push_back(std::abs(left(a)));
  }
  s.turn_p95 = p95(all);
  s.fitted_mount = degrees(nearestRotation(sum));
  s.turn_less_mount_p95 = p95(less);
  for (int a = 0; a < 3; ++a) s.turn_axes_p95(a) = p95(axis[a]);
}

}  // namespace

std::string describeScore(const std::string& name, const TruthScore& s) {
  char line[256];
  std::snprintf(line, sizeof(line),
                "%s: %.3f / %.3f m (first and last 20 s %.3f, elsewhere %.3f); %zu of %zu fixes "
                "rejected, %zu of the %zu more than 3 m off",
                name.c_str(), s.rmse, s.max, s.ends_max, s.middle_max, s.rejected, s.fixes,
                s.far_rejected, s.far);
  return line;
}

TruthScore scoreAgainstTruth(const TruthDrive& d, const GeoreferenceResult& r) {
  TruthScore s;
  const double first = d.input.poses.front().stamp, last = d.input.poses.back().stamp;
  ErrorAccumulator all;
  for (std::size_t i = 0; i < d.truth_at_pose.size() && i < r.rubbersheet.size(); ++i) {
    const double e = (r.rubbersheet[i].position - d.truth_at_pose[i].position).head<2>().norm();
    if (!std::isfinite(e)) continue;
    all.add(e);
    const double stamp = d.input.poses[i].stamp;
    const bool end = stamp < first + kEnds || stamp > last - kEnds;
    (end ? s.ends_max : s.middle_max) = std::max(end ? s.ends_max : s.middle_max, e);
  }
  const ErrorStats e = all.stats();
  s.rmse = e.rmse;
  s.max = e.max;
  scoreOrientations(d, r, s);
  if (!r.fusion) return s;
  for (const FixOutcome& o : r.fusion->fixes) {
    if (o.verdict != FixVerdict::kUsed && o.verdict != FixVerdict::kOutlier) continue;
    const bool rejected = o.verdict == FixVerdict::kOutlier;
    ++s.fixes;
    s.rejected += rejected;
    const Pose* t = truthAt(d, o.stamp);
    if (t && (o.position - t->position).head<2>().norm() > kFarFix) {
      ++s.far;
      s.far_rejected += rejected;
    }
  }
  return s;
}

Params simpleWay() {
  Params p;
  p.fusion = false;
  p.default_std_dev = 0.03;
  return p;
}

Params publishedMethod(int control_points) {
  Params p;
  p.fusion = false;
  p.control_points = control_points;
  p.refine_fraction = 0.0;
  p.max_time_offset = 0.0;
  p.smooth_jitter = false;
  p.default_std_dev = 0.03;  // urban GNSS gives none
  return p;
}

sim::SigmaCoverage sigmaCoverage(const TruthDrive& d, const GeoreferenceResult& r) {
  std::vector<Eigen::Vector3d> errors;
  std::vector<double> h, v;
  for (std::size_t i = 0; i < d.truth_at_pose.size() && i < r.rubbersheet.size(); ++i) {
    const Eigen::Vector3d e = r.rubbersheet[i].position - d.truth_at_pose[i].position;
    if (!e.allFinite() || i >= r.sigma.h.size()) continue;
    errors.push_back(e);
    h.push_back(r.sigma.h[i]);
    v.push_back(r.sigma.v[i]);
  }
  return sim::sigmaCoverage(errors, h, v);
}

namespace {

/// One row of the calibration table: the shares within the 95 % regions, the band calibrated
/// sigmas show on as many independent samples, the median sigma and the RMSE (m).
void printCoverageRow(const std::string& name, const sim::SigmaCoverage& c, double median,
                      double rmse) {
  const sim::CoverageBand h = sim::calibratedBand(c.independent_h),
                          v = sim::calibratedBand(c.independent_v);
  std::printf("| %s | %.1f / %.1f %% | %.0f-%.0f / %.0f-%.0f %% | %.0f / %.0f |", name.c_str(),
              100.0 * c.shareH(), 100.0 * c.shareV(), 100.0 * h.low, 100.0 * h.high, 100.0 * v.low,
              100.0 * v.high, c.independent_h, c.independent_v);
  if (median > 0.0) {
    std::printf(" %.3f / %.3f |\n", median, rmse);
  } else {
    std::printf(" - |\n");
  }
}

}  // namespace

void printCalibrationRows(const std::vector<CalibrationRow>& rows) {
  std::printf(
      "\n| drive | within 2.45 / 1.96 sigma, h / v | calibrated sigmas (99 %% of drives), h / v "
      "| independent samples, h / v | median sigma / RMSE (m) |\n|---|---:|---:|---:|---:|\n");
  sim::SigmaCoverage pooled[2];
  for (const CalibrationRow& row : rows) {
    printCoverageRow(row.name, row.coverage, row.median_h, row.rmse);
    pooled[row.name.find("urban") != std::string::npos] += row.coverage;
  }
  const char* kinds[] = {"all RTK", "all urban"};
  for (int k = 0; k < 2; ++k) {
    if (pooled[k].poses > 0.0) printCoverageRow(kinds[k], pooled[k], 0.0, 0.0);
  }
}

void printTruthDriveRows(const std::vector<std::string>& dirs, int control_points,
                         const std::vector<std::pair<std::string, std::string>>& sets,
                         double shift) {
  auto make = [&](bool fusion, double refine, double max_offset) {
    Params p;
    p.fusion = fusion;
    p.control_points = control_points;
    p.refine_fraction = refine;
    p.max_time_offset = max_offset;
    if (!fusion) p.default_std_dev = 0.03;  // urban GNSS gives none
    for (const auto& [k, v] : sets) paramTable().setText(p, k, v);
    return p;
  };
  Params published = publishedMethod(control_points);
  for (const auto& [k, v] : sets) paramTable().setText(published, k, v);
  const std::vector<std::pair<std::string, Params>> methods = {
      {"published method", published},
      {"fusion: false", make(false, Params().refine_fraction, Params().max_time_offset)},
      {"defaults", make(true, Params().refine_fraction, Params().max_time_offset)}};
  std::vector<CalibrationRow> calibration;
  for (const auto& dir : dirs) {
    for (const char* kind : {"rtk", "urban"}) {
      if (!std::filesystem::exists(dir + "/gnss_" + kind + ".txt")) continue;
      const TruthDrive d = loadTruthDrive(dir, kind, shift);
      for (const auto& [method, p] : methods) {
        const GeoreferenceResult r = georeference(d.input, p);
        const TruthScore s = scoreAgainstTruth(d, r);
        if (method == "defaults") {
          calibration.push_back({d.name, sigmaCoverage(d, r), r.sigma.median_h, s.rmse});
        }
        std::printf(
            "| %s | %s | %.3f | %.3f | %.3f | %.3f | %zu / %zu | %zu / %zu | %+.1f ms | %.2f | "
            "%.2f (%.2f / %.2f / %.2f) | %.2f |\n",
            d.name.c_str(), method.c_str(), s.rmse, s.max, s.ends_max, s.middle_max, s.rejected,
            s.fixes, s.far_rejected, s.far, 1e3 * (r.clock_offset - shift + d.lag), s.turn_p95,
            s.turn_less_mount_p95, s.turn_axes_p95.x(), s.turn_axes_p95.y(), s.turn_axes_p95.z(),
            s.fitted_mount.norm());
        std::fflush(stdout);
      }
    }
  }
  printCalibrationRows(calibration);
}

}  // namespace flexcloud::study
