// The pose sigmas against the simulator's truth on every scenario of the accuracy study (seed
// 1): the share of poses within 2.45 sigma horizontally and 1.96 sigma vertically, and the
// median sigma against the trajectory's RMSE (doc/ACCURACY.md). The KITTI drives are checked in
// test_truth_drives.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "flexcloud/georeference.h"
#include "flexcloud/sim/scenarios.h"
#include "flexcloud/sim/truth_metrics.h"
#include "flexcloud/uncertainty/point_sigma.h"
#include "test_util.h"

namespace flexcloud {
namespace {

const char* const kScenarios[] = {"city_ins_10hz",     "figure_eight",       "loop_closures",
                                  "loop_offset_lever", "loop_rtk",           "loop_unclosed",
                                  "loop_urban",        "loop_urban_nocov",   "open_gnss_late",
                                  "open_height_drift", "open_rtk",           "open_rtk_drifting",
                                  "open_urban",        "open_urban_end",     "open_varying_drift",
                                  "race_track",        "urban_keyframes_1hz"};

/// The truth at instant t (linear between its poses, which share the SLAM's stamps).
Eigen::Vector3d truthAt(const Trajectory& truth, double t, std::size_t& k) {
  while (k + 2 < truth.size() && truth[k + 1].stamp <= t) ++k;
  const double span = truth[k + 1].stamp - truth[k].stamp;
  const double u = span > 0.0 ? std::clamp((t - truth[k].stamp) / span, 0.0, 1.0) : 0.0;
  return truth[k].position + u * (truth[k + 1].position - truth[k].position);
}

/// The defaults at the simulator's datum, with the drive's lever arm.
Params paramsFor(const sim::SimDrive& d) {
  Params p = test::atSimDatum(d, Params{});
  p.lever_arm_x = d.params.lever_arm.x(), p.lever_arm_y = d.params.lever_arm.y();
  p.lever_arm_z = d.params.lever_arm.z();
  return p;
}

struct Calibration {
  sim::SigmaCoverage coverage;
  double rmse = 0.0;
};

Calibration calibration(const GeoreferenceResult& r, const Trajectory& truth) {
  std::vector<Eigen::Vector3d> errors;
  double squares = 0.0;
  std::size_t k = 0;
  for (const Pose& p : r.rubbersheet) {
    errors.push_back(p.position - truthAt(truth, p.stamp, k));
    squares += errors.back().head<2>().squaredNorm();
  }
  return {sim::sigmaCoverage(errors, r.sigma.h, r.sigma.v),
          std::sqrt(squares / static_cast<double>(errors.size()))};
}

// At least 85 % within the 95 % circle on every drive, and 80 % vertically, but on
// open_urban_end, whose last 35 s of false RTK fixes show no fault of their own and are followed:
// its sigma holds the fixes' claim there (83.1 %), at least 80 %. On city_ins_10hz
// the GNSS/INS's error wanders smoothly (2 cm over 20 s) and the result follows it: the share of
// its reported 4 cm vertical std-dev beyond its white noise is an error its fixes share, and
// counts (97.9 %; read as white noise averaged over many fixes, 35 %). The median sigma within
// twice the RMSE, but on open_height_drift and open_varying_drift, where the clock's sigma (from
// its profiles) is several times its true error and the speed times it makes up most of the
// sigma (2.8x, 2.5x), and on urban_keyframes_1hz, whose keyframe graph jumps by decimetres: the
// walk's intensity learned from its fixes (0.03 m^2 per m, one Gaussian for the jumps and the
// metres between them) speaks for every metre, 3.1x a trajectory 0.39 m off the truth: within
// 3.5 times there.
// Pooled, 93-98 % both ways: 96.8 / 95.7 % of about 2000 independent samples, where calibrated
// sigmas show 94-96 %.
TEST(SigmaCalibration, SimulatedDrivesAgainstTheirTruth) {
  sim::SigmaCoverage pooled;
  for (const char* name : kScenarios) {
    const sim::SimDrive d = sim::simulateDrive(sim::scenario(name, 1, 1000));
    const GeoreferenceResult r = georeference(test::inputOf(d), paramsFor(d));
    const Calibration c = calibration(r, d.truth);
    const sim::SigmaCoverage& s = c.coverage;
    std::printf(
        "%s: %.1f %% within 2.45 sigma, %.1f %% within 1.96 sigma vertical (%.0f / %.0f "
        "independent samples), median sigma %.3f m, RMSE %.3f m\n",
        name, 100.0 * s.shareH(), 100.0 * s.shareV(), s.independent_h, s.independent_v,
        r.sigma.median_h, c.rmse);
    const std::string n = name;
    EXPECT_GE(s.shareH(), n == "open_urban_end" ? 0.80 : 0.85) << n;
    EXPECT_GE(s.shareV(), 0.80) << n;
    pooled += s;
    const bool cautious = n == "loop_offset_lever" || n == "open_height_drift" ||
                          n == "open_varying_drift" || n == "urban_keyframes_1hz";
    EXPECT_LE(r.sigma.median_h, (cautious ? 3.5 : 2.0) * c.rmse) << n;
  }
  const sim::CoverageBand h = sim::calibratedBand(pooled.independent_h),
                          v = sim::calibratedBand(pooled.independent_v);
  std::printf("pooled: %.1f %% (%.1f-%.1f) / %.1f %% (%.1f-%.1f), %.0f / %.0f samples\n",
              100.0 * pooled.shareH(), 100.0 * h.low, 100.0 * h.high, 100.0 * pooled.shareV(),
              100.0 * v.low, 100.0 * v.high, pooled.independent_h, pooled.independent_v);
  EXPECT_GE(pooled.shareH(), 0.93);
  EXPECT_LE(pooled.shareH(), 0.98);
  EXPECT_GE(pooled.shareV(), 0.93);
  EXPECT_LE(pooled.shareV(), 0.98);
}

// The receiver's first fix 30 s after the SLAM's first pose, its last 30 s before its last: the
/// Shares of map points within 2.45 sigma_h of their true place, by distance from the route.
struct PointShares {
  static constexpr int kBands = 3;  // 0-5, 5-15, 15-30 m
  double within[kBands] = {0, 0, 0};
  double points[kBands] = {0, 0, 0};
  double within_v = 0.0, all = 0.0;
  double max_sigma_h = 0.0, max_error_h = 0.0;  // within 30 m of the route
  std::vector<double> sigma_h;                  // every point's within 30 m
  double error2 = 0.0;                          // their summed squared horizontal errors
  double share(int b) const { return points[b] > 0 ? within[b] / points[b] : 0.0; }
};

int bandOf(double lateral) {
  return lateral < 5.0 ? 0 : lateral < 15.0 ? 1 : lateral < 30.0 ? 2 : -1;
}

PointShares pointShares(const sim::SimDrive& d, const GeoreferenceResult& r) {
  const PointSigmaField field(r.rubbersheet, r.sigma, *r.sheet);
  PointShares s;
  for (std::size_t i = 0; i < d.map.slam.size(); ++i) {
    const RubberSheet::Location at = r.sheet->locate(d.map.slam[i]);
    const Eigen::Vector3d p = RubberSheet::apply(r.sheet->affineAt(at), d.map.slam[i]);
    const PointSigma sigma = field.at(p, at.outside ? -1 : at.tet);
    const Eigen::Vector3d e = p - d.map.truth[i];
    s.all += 1;
    s.within_v += std::abs(e.z()) <= 1.96 * sigma.v;
    const int b = bandOf(d.map.lateral[i]);
    if (b < 0) continue;
    s.points[b] += 1;
    s.within[b] += e.head<2>().norm() <= 2.45 * sigma.h;
    s.max_sigma_h = std::max(s.max_sigma_h, static_cast<double>(sigma.h));
    s.max_error_h = std::max(s.max_error_h, e.head<2>().norm());
    s.sigma_h.push_back(sigma.h);
    s.error2 += e.head<2>().squaredNorm();
  }
  return s;
}

// The map points' sigmas against the simulator's true map: at least 80 % of the points within
// 2.45 sigma_h of their true place in every band of distance from the route (89-100 % today),
// and 75 % within 1.96 sigma_v (77-100 %). Where the poses' sigmas cover their errors with room
// to spare (100 % on the urban drives), so do the points': the 99 % ceiling of the calibration
// is not met there (doc/ACCURACY.md). No point's sigma_h beyond ten times the largest error and
// 1.5 m: a sliver tetrahedron's own strain gave points of a centimetre map kilometres. (On
// open_rtk, 7 of 20,000 points 8 m below the road lie in a tetrahedron that reaches a corner of
// the cuboid, and their sigma carries its change of length: 1.02 m, the error 0.03 m.)
TEST(SigmaCalibration, SimulatedMapPointsAgainstTheirTruth) {
  for (const char* name : kScenarios) {
    const sim::SimDrive d = sim::simulateDrive(sim::scenario(name, 1, 20000));
    PointShares s = pointShares(d, georeference(test::inputOf(d), paramsFor(d)));
    std::nth_element(s.sigma_h.begin(), s.sigma_h.begin() + s.sigma_h.size() / 2, s.sigma_h.end());
    const double median = s.sigma_h[s.sigma_h.size() / 2];
    const double rmse = std::sqrt(s.error2 / static_cast<double>(s.sigma_h.size()));
    std::printf(
        "%s points within 2.45 sigma_h: %.1f %% (0-5 m, %.0f), %.1f %% (5-15 m, %.0f), %.1f %% "
        "(15-30 m, %.0f); within 1.96 sigma_v %.1f %%; sigma_h median %.3f m, largest %.3f m; "
        "error RMSE %.3f m, largest %.3f m\n",
        name, 100 * s.share(0), s.points[0], 100 * s.share(1), s.points[1], 100 * s.share(2),
        s.points[2], 100 * s.within_v / s.all, median, s.max_sigma_h, rmse, s.max_error_h);
    for (int b = 0; b < PointShares::kBands; ++b) {
      if (s.points[b] < 200) continue;
      EXPECT_GE(s.share(b), 0.80) << name << " band " << b;
    }
    EXPECT_GE(s.within_v / s.all, 0.75) << name;
    EXPECT_LE(s.max_sigma_h, 10.0 * s.max_error_h + 1.5)
        << name << ": no point far less certain than the worst is wrong";
  }
}

// A SLAM whose every pose is off by 1.5 cm of its own (SlamErrors::pose_jitter, as KITTI's LiDAR
// odometry): the jitter measured, taken out of the trajectory (against the truth, RTK: half the
// error), and the pose sigmas, which count what is left of it, within 85-99 % both ways.
TEST(SigmaCalibration, ASlamsJitterIsTakenOutAndCovered) {
  for (const char* name : {"loop_rtk", "open_rtk", "loop_urban"}) {
    sim::SimParams sp = sim::scenario(name, 1, 1000);
    sp.slam_errors.pose_jitter = 0.015;
    const sim::SimDrive d = sim::simulateDrive(sp);
    const GeoreferenceResult r = georeference(test::inputOf(d), paramsFor(d));
    Params raw = paramsFor(d);
    raw.smooth_jitter = false;
    const Calibration c = calibration(r, d.truth);
    const Calibration u = calibration(georeference(test::inputOf(d), raw), d.truth);
    std::printf(
        "%s with 1.5 cm of jitter: measured %.4f m, %d poses either side; RMSE %.4f m (unsmoothed "
        "%.4f m); %.1f %% within 2.45 sigma, %.1f %% within 1.96 sigma vertical\n",
        name, r.jitter.white, r.jitter.half_width, c.rmse, u.rmse, 100.0 * c.coverage.shareH(),
        100.0 * c.coverage.shareV());
    EXPECT_NEAR(r.jitter.white, 0.015, 0.0015) << name;
    EXPECT_GE(r.jitter.half_width, 4) << name;
    EXPECT_LT(c.rmse, (std::string(name) == "loop_urban" ? 0.9 : 0.6) * u.rmse) << name;
    EXPECT_GE(c.coverage.shareH(), 0.85) << name;
    EXPECT_LE(c.coverage.shareH(), 0.99) << name;
    EXPECT_GE(c.coverage.shareV(), 0.85) << name;
    EXPECT_LE(c.coverage.shareV(), 0.99) << name;
  }
}

// The receiver's first fix 30 s after the SLAM's first pose, its last 30 s before its last: the
// least certain stretch is one of those ends, where the result is metres off the truth, and it
// is warned of beyond max_sigma_h (and not with max_sigma_h 0 or above it). Beyond the fixes the
// sigma grows too slowly: 1.0 m where the truth is 2.3 m off at the last pose, 0.9 m where it is
// 5.9 m off at the first.
TEST(SigmaCalibration, TheLeastCertainStretchIsWarnedOf) {
  const sim::SimDrive d = sim::simulateDrive(sim::scenario("open_gnss_late", 1, 1000));
  const GeoreferenceResult r = georeference(test::inputOf(d), test::atSimDatum(d, Params{}));
  const PoseSigmas& s = r.sigma;
  const double first = r.rubbersheet.front().stamp, last = r.rubbersheet.back().stamp;
  std::printf("open_gnss_late: least certain %.1f-%.1f s of %.1f s, sigma %.3f m\n",
              s.worst.from - first, s.worst.to - first, last - first, s.worst.sigma_h);
  EXPECT_TRUE(s.worst.to - first < 35.0 || last - s.worst.from < 35.0);
  double error_there = 0.0;
  std::size_t k = 0;
  for (const Pose& p : r.rubbersheet) {
    const double e = (p.position - truthAt(d.truth, p.stamp, k)).head<2>().norm();
    if (p.stamp >= s.worst.from && p.stamp <= s.worst.to) error_there = std::max(error_there, e);
  }
  EXPECT_GT(error_there, 1.0);
  EXPECT_GT(s.worst.sigma_h, 0.5);
  const std::string w = sigmaWarning(s, 0.5);
  EXPECT_EQ(w.rfind("uncertain: from ", 0), 0u) << w;
  EXPECT_NE(w.find("beyond max_sigma_h (0.500 m)"), std::string::npos) << w;
  // Among the result's warnings, with the seconds into the drive beside the epoch stamps.
  char into[64];
  std::snprintf(into, sizeof(into), " s (%.1f-%.1f s into the drive)", s.worst.from - first,
                s.worst.to - first);
  const std::string::size_type cut = w.find(" s ");
  const std::string expected = w.substr(0, cut) + into + w.substr(cut + 2);
  bool listed = false;
  for (const auto& x : resultWarnings(r, Params{}, nullptr)) listed = listed || x == expected;
  EXPECT_TRUE(listed) << expected;
  EXPECT_EQ(sigmaWarning(s, 0.0), "");
  EXPECT_EQ(sigmaWarning(s, s.worst.sigma_h + 0.01), "");
}

}  // namespace
}  // namespace flexcloud
