// The simulator's SLAM failures, motion and GNSS/INS error (sim/slam_errors.h), each measured on
// the drive it makes: what the tests of the pipeline rely on must be in the drives.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "flexcloud/geo/geodesy.h"
#include "flexcloud/metrics.h"
#include "flexcloud/sim/drive_simulator.h"
#include "flexcloud/sim/scenarios.h"

namespace flexcloud::sim {
namespace {

SimParams small(const std::string& name, std::uint64_t seed = 1) {
  return scenario(name, seed, 1000);
}

/// Path driven between poses i and i + 1 of the truth.
double step(const Trajectory& t, std::size_t i) {
  return (t[i + 1].position - t[i].position).norm();
}

TEST(Simulator, AKeyframeSlamKeepsAPoseEveryOneToThreeMetres) {
  const SimDrive d = simulateDrive(small("urban_keyframes_1hz"));
  ASSERT_EQ(d.slam.size(), d.truth.size());
  std::size_t long_gaps = 0;
  for (std::size_t i = 0; i + 2 < d.truth.size(); ++i) {  // the last keyframe closes the drive
    const double s = step(d.truth, i);
    EXPECT_GT(s, 0.99) << i;
    // A 10 Hz pose comes after 1-3 m, or within one pose's travel (14 m/s: 1.4 m) beyond.
    EXPECT_LT(s, 3.0 + 1.41) << i;
    long_gaps += d.truth[i + 1].stamp - d.truth[i].stamp > 15.0 ? 1 : 0;
  }
  EXPECT_EQ(long_gaps, 1u);  // the 20 s stop
  // Every GNSS fix at 1 Hz, none with a covariance.
  for (const auto& f : d.fixes) EXPECT_TRUE(f.fix.std_enu.hasNaN());
  EXPECT_NEAR(d.fixes[1].fix.stamp - d.fixes[0].fix.stamp, 1.0, 1e-9);
}

TEST(Simulator, ARaceCarBrakesFromEightyMetresPerSecondIntoTheCurves) {
  SimParams p = small("race_track");
  p.slam_errors.keyframe_max_m = 0.0;
  const SimDrive d = simulateDrive(p);
  std::vector<double> v;
  for (std::size_t i = 0; i + 1 < d.truth.size(); ++i) {
    v.push_back(step(d.truth, i) / (d.truth[i + 1].stamp - d.truth[i].stamp));
  }
  const double top = *std::max_element(v.begin(), v.end());
  EXPECT_LE(top, 80.0 + 1e-3);
  EXPECT_GT(top, 75.0);
  // Away from the start and the end the car never drops below the curves' limit, well above
  // a city's speeds, and the speed changes: it brakes into every curve.
  std::vector<double> middle(v.begin() + v.size() / 10, v.end() - v.size() / 10);
  const double slowest = *std::min_element(middle.begin(), middle.end());
  EXPECT_GT(slowest, 30.0);
  EXPECT_LT(slowest, 70.0);
  std::size_t braking = 0;
  for (std::size_t i = 1; i < middle.size(); ++i) {
    const double a = (middle[i] - middle[i - 1]) * p.odom_rate;
    EXPECT_GT(a, -p.max_brake - 1.0);
    braking += a < -5.0 ? 1 : 0;
  }
  EXPECT_GT(braking, 10u);
}

/// The jumps of the SLAM trajectory beyond the true motion between two poses (m).
std::vector<double> jumps(const SimDrive& d) {
  std::vector<double> out;
  for (std::size_t i = 0; i + 1 < d.slam.size(); ++i) {
    out.push_back(
        std::abs((d.slam[i + 1].position - d.slam[i].position).norm() - step(d.truth, i)));
  }
  return out;
}

TEST(Simulator, APoseGraphSnapsHalfAMetreToThreeAtItsClosures) {
  const SimDrive d = simulateDrive(small("loop_closures"));
  std::size_t snaps = 0;
  for (double j : jumps(d)) {
    if (j < 0.1) continue;
    ++snaps;
    EXPECT_LT(j, 3.0 + 0.1);
  }
  // Closures at the end of the first lap, then every 200-600 m of the two laps after it.
  EXPECT_GE(snaps, 1u + 4000 / 600);
  EXPECT_LE(snaps, 1u + 4000 / 200);
  // Without closures the same drive has no such jump.
  SimParams p = small("loop_closures");
  p.slam_errors.closures = false;
  p.close_each_lap = false;
  p.close_loop = false;
  for (double j : jumps(simulateDrive(p))) EXPECT_LT(j, 0.1);
}

TEST(Simulator, HeightDriftsByTensOfMetresWithoutAPitchError) {
  const SimDrive d = simulateDrive(small("open_height_drift"));
  const Eigen::Vector3d start = d.slam.front().position;
  double worst_z = 0.0, worst_pitch = 0.0;
  for (std::size_t i = 0; i < d.slam.size(); ++i) {
    // The SLAM frame starts at the first true pose: compare heights in it.
    const Eigen::Vector3d truth =
        d.truth.front().orientation.inverse() * (d.truth[i].position - d.truth.front().position);
    worst_z = std::max(worst_z, std::abs(d.slam[i].position.z() - start.z() - truth.z()));
    const Eigen::Vector3d fwd = d.slam[i].orientation * Eigen::Vector3d::UnitX();
    const Eigen::Vector3d fwd_true =
        d.truth.front().orientation.inverse() * (d.truth[i].orientation * Eigen::Vector3d::UnitX());
    worst_pitch = std::max(worst_pitch, std::abs(std::asin(fwd.z()) - std::asin(fwd_true.z())));
  }
  EXPECT_GT(worst_z, 10.0);
  // The steady pitch drift of 0.04 deg/100 m over 5 km: 2 deg at most, which over the route
  // explains a fraction of that height.
  EXPECT_LT(worst_pitch * 180.0 / 3.14159265358979, 2.5);
}

TEST(Simulator, AnUnclosedLoopEndsWhereItBeganButNotInTheSlamsMap) {
  const SimDrive d = simulateDrive(small("loop_unclosed"));
  EXPECT_LT((d.truth.back().position - d.truth.front().position).norm(), 1.0);
  EXPECT_GT((d.slam.back().position - d.slam.front().position).norm(), 10.0);
}

TEST(Simulator, AFigureEightCrossesItselfOnABridge) {
  const SimParams p = small("figure_eight");
  const SimDrive d = simulateDrive(p);
  double closest = 1e9, height = 0.0;
  const auto n = d.truth.size();
  for (std::size_t i = 0; i < n; i += 2) {
    for (std::size_t j = i + n / 4; j < i + 3 * n / 4 && j < n; j += 2) {
      const Eigen::Vector3d dx = d.truth[j].position - d.truth[i].position;
      if (dx.head<2>().norm() < closest) closest = dx.head<2>().norm(), height = std::abs(dx.z());
    }
  }
  EXPECT_LT(closest, 2.0);
  EXPECT_NEAR(height, p.bridge_height, 0.5);
}

TEST(Simulator, GnssInsErrorsWanderSlowly) {
  const SimDrive d = simulateDrive(small("city_ins_10hz"));
  const EnuFrame enu(d.datum);
  std::vector<double> e;
  for (std::size_t j = 0; j < d.fixes.size(); ++j) {
    // The true antenna at the fix's instant: the poses are at 10 Hz like the fixes.
    const double t = d.fixes[j].fix.stamp + d.params.clock_offset;
    const std::size_t i = static_cast<std::size_t>(std::lround((t - d.truth.front().stamp) * 10.0));
    if (i >= d.truth.size()) break;
    const auto& f = d.fixes[j].fix;
    e.push_back((enu.toEnu(f.lat, f.lon, f.alt) - d.truth[i].position).x());
  }
  double mean = 0.0;
  for (double x : e) mean += x / static_cast<double>(e.size());
  double var = 0.0, lag = 0.0;
  for (std::size_t k = 0; k < e.size(); ++k) {
    var += (e[k] - mean) * (e[k] - mean);
    if (k > 0) lag += (e[k] - mean) * (e[k - 1] - mean);
  }
  const double sigma = std::sqrt(var / static_cast<double>(e.size()));
  EXPECT_GT(sigma, 0.01);  // 2 cm wandering, 5 mm white
  EXPECT_LT(sigma, 0.04);
  EXPECT_GT(lag / var, 0.9);  // from fix to fix it hardly changes
}

/// The SLAM's heading error (rad) every `every` poses, in its own frame.
std::vector<double> headingErrors(const SimDrive& d, std::size_t every) {
  std::vector<double> out;
  for (std::size_t i = 0; i < d.slam.size(); i += every) {
    const Eigen::Vector3d a = d.slam[i].orientation * Eigen::Vector3d::UnitX();
    const Eigen::Vector3d b =
        d.truth.front().orientation.inverse() * (d.truth[i].orientation * Eigen::Vector3d::UnitX());
    out.push_back(std::atan2(a.x() * b.y() - a.y() * b.x(), a.x() * b.x() + a.y() * b.y()));
  }
  return out;
}

/// The spread (1-sigma) of the heading error's rate of change between samples.
double rateSpread(const std::vector<double>& e) {
  std::vector<double> r;
  for (std::size_t k = 1; k < e.size(); ++k) r.push_back(e[k] - e[k - 1]);
  double mean = 0.0, var = 0.0;
  for (double x : r) mean += x / static_cast<double>(r.size());
  for (double x : r) var += (x - mean) * (x - mean) / static_cast<double>(r.size());
  return std::sqrt(var);
}

TEST(Simulator, DriftWhoseRateChangesAlongTheRoute) {
  // Stronger rotation walks in degenerate stretches and a heading rate that changes from
  // stretch to stretch: the heading error's rate wanders far more than the steady drift's.
  SimParams p = small("open_varying_drift");
  SimParams steady = p;
  steady.slam_errors = SlamErrors{};
  for (std::uint64_t seed : {1, 2, 3}) {
    p.seed = steady.seed = seed;
    const double varying = rateSpread(headingErrors(simulateDrive(p), 150));
    const double fixed = rateSpread(headingErrors(simulateDrive(steady), 150));
    EXPECT_GT(varying, 2.0 * fixed) << "seed " << seed;
  }
  // Switched off, the drive is the steady one to the bit: the failures draw from a generator
  // of their own.
  p.slam_errors.degenerate_share = 0.0;
  p.slam_errors.heading_bias_change = 0.0;
  const SimDrive a = simulateDrive(p), b = simulateDrive(steady);
  ASSERT_EQ(a.slam.size(), b.slam.size());
  for (std::size_t i = 0; i < a.slam.size(); ++i) EXPECT_EQ(a.slam[i].position, b.slam[i].position);
}

}  // namespace
}  // namespace flexcloud::sim
