// Accuracy against the ground truth with the GNSS that real streets give (issue 9's targets):
// the map by distance from the route and the trajectory, on several simulator seeds, against
// the published method on the same drives.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "flexcloud/georeference.h"
#include "flexcloud/sim/scenarios.h"
#include "flexcloud/sim/truth_metrics.h"
#include "test_util.h"

namespace flexcloud {
namespace {

/// The figures recorded on a fresh clone (200 control points, the largest of seeds 1-3, m); the
/// tests allow half as much again, so a regression of 1.5x fails. open_urban_end's multipath
/// episodes claim RTK precision without scatter, and its last 35 s of false RTK fixes ramp in
/// over 2 s with no fix of another claim around them: nothing in the GNSS shows their fault,
/// and fixes that claim precision and agree with each other are followed (on every real drive
/// seen, such a stretch was the SLAM failing): 0.812 / 0.778 / 0.797 m before.
struct Target {
  const char* scenario;
  double map_rmse;         ///< all points
  double far_rmse;         ///< points 15-30 m from the route
  double trajectory_rmse;  ///< the rubber-sheeted trajectory
};

constexpr double kSlack = 1.5;
constexpr Target kTargets[] = {{"loop_rtk", 0.034, 0.041, 0.009},
                               {"open_rtk", 0.035, 0.046, 0.009},
                               {"loop_urban", 0.066, 0.071, 0.060},
                               {"open_urban", 0.077, 0.082, 0.071},
                               {"open_urban_end", 1.768, 1.576, 2.250}};

struct Outcome {
  sim::MapTruthErrors map;
  ErrorStats trajectory;
  GeoreferenceResult result;
};

Outcome run(const sim::SimDrive& d, Params p) {
  p = test::atSimDatum(d, p);
  Outcome o{{}, {}, georeference(test::inputOf(d), p)};
  o.map = sim::mapTruthErrors(d.map, *o.result.sheet);
  o.trajectory = sim::trajectoryTruthError(o.result.rubbersheet, d.truth);
  return o;
}

/// The published method: the GNSS at the poses, control points every len/N, no fusion.
Params published() {
  Params p;
  p.fusion = false;
  p.max_time_offset = 0.0;  // the GNSS at the poses' stamps as given
  p.smooth_jitter = false;
  p.refine_fraction = 0.0;
  return p;
}

class Accuracy : public ::testing::TestWithParam<Target> {};

TEST_P(Accuracy, MapAndTrajectoryAgainstTheTruthOnThreeSeeds) {
  const Target t = GetParam();
  for (std::uint64_t seed : {1, 2, 3}) {
    const sim::SimDrive d = sim::simulateDrive(sim::scenario(t.scenario, seed, 50000));
    const Outcome f = run(d, Params{});
    const Outcome p = run(d, published());
    std::printf(
        "%s seed %lu: map RMSE %.3f (0-5 m %.3f, 5-15 m %.3f, 15-30 m %.3f), trajectory "
        "%.3f m; published method %.3f / %.3f m; %zu fixes rejected\n",
        t.scenario, static_cast<unsigned long>(seed), f.map.all.rmse, f.map.near.rmse,
        f.map.mid.rmse, f.map.far.rmse, f.trajectory.rmse, p.map.all.rmse, p.trajectory.rmse,
        f.result.fusion->outliers);
    std::printf("  recorded %.3f / %.3f / %.3f m, bounds %.3f / %.3f / %.3f m\n", t.map_rmse,
                t.far_rmse, t.trajectory_rmse, kSlack * t.map_rmse, kSlack * t.far_rmse,
                kSlack * t.trajectory_rmse);
    EXPECT_LE(f.map.all.rmse, kSlack * t.map_rmse) << t.scenario << " seed " << seed;
    EXPECT_LE(f.map.far.rmse, kSlack * t.far_rmse) << t.scenario << " seed " << seed;
    EXPECT_LT(f.map.all.rmse, p.map.all.rmse) << t.scenario << " seed " << seed;
    EXPECT_LE(f.trajectory.rmse, kSlack * t.trajectory_rmse) << t.scenario << " seed " << seed;
    // The simulated SLAM drifts as the default noise says: the check does not raise it (a raise
    // is at least 1.5x).
    EXPECT_LT(f.result.fusion->slam_noise_scale, 1.05) << t.scenario << " seed " << seed;
  }
}

INSTANTIATE_TEST_SUITE_P(Targets, Accuracy, ::testing::ValuesIn(kTargets),
                         [](const auto& info) { return std::string(info.param.scenario); });

/// Fixes without any covariance: their std-dev is estimated from the residuals.
TEST(AccuracyMore, UrbanGnssWithoutCovarianceIsEstimated) {
  const sim::SimDrive d = sim::simulateDrive(sim::scenario("loop_urban_nocov", 2, 50000));
  const Outcome f = run(d, Params{});
  std::printf("loop_urban_nocov seed 2: map RMSE %.3f m, estimated std-dev %.3f m (h) %.3f (v)\n",
              f.map.all.rmse, f.result.fusion->estimated_std_h, f.result.fusion->estimated_std_v);
  EXPECT_LE(f.map.all.rmse, kSlack * 0.050);  // recorded 0.050 m
  // The simulator's white noise of these fixes (its multipath, float fixes and outliers stay
  // out of the estimate): 0.017 m estimated on a fresh clone, against 0.015 m.
  const double noise = sim::scenario("loop_urban_nocov", 2, 50000).gnss_noise_h;
  EXPECT_GT(f.result.fusion->estimated_std_h, 0.7 * noise);
  EXPECT_LT(f.result.fusion->estimated_std_h, 1.3 * noise);
}

/// A lever arm given as a parameter is applied, and a clock offset is estimated where the
/// speed changes (a stop). The fixes of the stop and of the braking before it are paired with
/// the poses of their true time: the trajectory stays on the truth (with the offset taken the
/// wrong way round where the SLAM's jitter is measured, seed 3 ended 0.2 m off).
TEST(AccuracyMore, LeverArmAppliedAndClockOffsetEstimated) {
  Params p;
  p.lever_arm_x = 1.2;
  p.lever_arm_y = -0.4;
  p.lever_arm_z = 1.6;
  for (std::uint64_t seed : {1, 3}) {
    const sim::SimDrive d = sim::simulateDrive(sim::scenario("loop_offset_lever", seed, 50000));
    const Outcome f = run(d, p);
    std::printf(
        "loop_offset_lever seed %lu: map RMSE %.3f m, trajectory %.3f m (clock offset %.3f s), "
        "%zu poses moved to the fixes\n",
        static_cast<unsigned long>(seed), f.map.all.rmse, f.trajectory.rmse,
        f.result.fusion->time_offset, f.result.fusion->detail_poses);
    EXPECT_NEAR(f.result.fusion->time_offset, -0.5, 0.01) << seed;
    EXPECT_TRUE(f.result.fusion->time_offset_estimated) << seed;  // the stop shows it
    EXPECT_NEAR(f.result.fusion->time_offset_from_speed, -0.5, 0.05) << seed;
    EXPECT_LE(f.map.all.rmse, kSlack * 0.037) << seed;     // recorded 0.037 m (seed 1)
    EXPECT_LE(f.trajectory.rmse, kSlack * 0.011) << seed;  // recorded 0.011 m (seed 1)
    if (seed != 1) continue;
    const Outcome without = run(d, Params{});
    std::printf("  %.3f m without the lever arm\n", without.map.all.rmse);
    EXPECT_GT(without.map.all.rmse, 1.0);  // the antenna is 2 m from the body origin
  }
}

/// The rubber-sheeted trajectory against the truth of the drive's GNSS antenna (its lever arm
/// from the poses' origin).
ErrorStats againstAntennaTruth(const sim::SimDrive& d, const GeoreferenceResult& r) {
  Trajectory antenna = d.truth;
  for (Pose& t : antenna) t.position += t.orientation * d.params.lever_arm;
  return sim::trajectoryTruthError(r.rubbersheet, antenna);
}

/// With no lever arm given, the fusion estimates the antenna's horizontal offset from the
/// poses' origin (here 1.2 m ahead, 0.4 m right, 1.6 m up), and the trajectory is the antenna's
/// as without the estimate. In a fit of positions an offset along the track passes for a clock
/// offset: estimated, it leaves the clock to the speed profiles' stop.
TEST(AccuracyMore, AntennaOffsetEstimatedWhereNoLeverArmIsGiven) {
  for (std::uint64_t seed : {1, 3}) {
    const sim::SimDrive d = sim::simulateDrive(sim::scenario("loop_offset_lever", seed, 50000));
    const Outcome f = run(d, Params{});
    const FusionResult& fusion = *f.result.fusion;
    const ErrorStats e = againstAntennaTruth(d, f.result);
    std::printf(
        "loop_offset_lever seed %lu, no lever arm given: antenna (%.3f, %.3f) m, clock "
        "%.3f s, trajectory against the antenna's truth %.3f m\n",
        static_cast<unsigned long>(seed), fusion.antenna_offset.x(), fusion.antenna_offset.y(),
        fusion.time_offset, e.rmse);
    EXPECT_TRUE(fusion.antenna_offset_estimated);
    // recorded (1.164, -0.425) and (1.247, -0.334) m
    EXPECT_NEAR(fusion.antenna_offset.x(), 1.2, 0.1) << seed;
    EXPECT_NEAR(fusion.antenna_offset.y(), -0.4, 0.1) << seed;
    EXPECT_NEAR(fusion.time_offset, -0.5, 0.01) << seed;
    EXPECT_LE(e.rmse, kSlack * 0.011) << seed;  // recorded 0.009 m, as with it given
    EXPECT_EQ(fusion.lever_arm, Eigen::Vector3d::Zero());
    const std::vector<std::string> warnings = resultWarnings(f.result, Params{}, nullptr);
    EXPECT_EQ(std::count_if(warnings.begin(), warnings.end(),
                            [](const std::string& w) {
                              return w.rfind("lever arm: the drive puts the GNSS antenna at x 1.",
                                             0) == 0;
                            }),
              1)
        << seed;
  }
  Params given;
  given.lever_arm_x = 1.2;
  const sim::SimDrive d = sim::simulateDrive(sim::scenario("loop_offset_lever", 1, 50000));
  const Outcome g = run(d, given);
  EXPECT_FALSE(g.result.fusion->antenna_offset_estimated);  // a lever arm given is taken as is
  // The stamps put right by gnss_time_offset: no clock offset is left to estimate, but the
  // speed profile shows the clock (it would show one), and the turns the antenna.
  Params stamped;
  stamped.gnss_time_offset = d.params.clock_offset;
  const Outcome s = run(d, stamped);
  const FusionResult& sf = *s.result.fusion;
  const ErrorStats e = againstAntennaTruth(d, s.result);
  std::printf(
      "loop_offset_lever, stamps put right: antenna (%.3f, %.3f) m, clock %.4f s, "
      "trajectory against the antenna's truth %.3f m\n",
      sf.antenna_offset.x(), sf.antenna_offset.y(), sf.time_offset, e.rmse);
  EXPECT_TRUE(sf.antenna_offset_estimated);
  EXPECT_NEAR(sf.antenna_offset.x(), 1.2, 0.1);
  EXPECT_NEAR(sf.antenna_offset.y(), -0.4, 0.1);
  EXPECT_LE(e.rmse, kSlack * 0.011);
}

/// A SLAM whose heading wanders ten times as much as the fusion's noise says, at an even speed:
/// in a fit of positions the drift passed for a clock offset (0.08 s, 1 m along the track);
/// the speed profiles show none, so none is estimated. Nor does it pass for an antenna's offset
/// along the track, which moves the fixes as a clock offset does (0.56-1.14 m at 3.4-7.3 sigma
/// before the offset was left to drives whose speed profile shows the clock).
TEST(AccuracyMore, AWanderingSlamHeadingDoesNotPassForAClockOffset) {
  for (std::uint64_t seed : {1, 2, 3}) {
    const sim::SimDrive d = sim::simulateDrive(sim::scenario("open_rtk_drifting", seed, 50000));
    const Outcome f = run(d, Params{});
    const Outcome p = run(d, published());
    std::printf(
        "open_rtk_drifting seed %lu: map RMSE %.3f, trajectory %.3f m (published %.3f / %.3f "
        "m), clock offset %s\n",
        static_cast<unsigned long>(seed), f.map.all.rmse, f.trajectory.rmse, p.map.all.rmse,
        p.trajectory.rmse, f.result.fusion->time_offset_estimated ? "estimated" : "not shown");
    EXPECT_FALSE(f.result.fusion->time_offset_estimated);
    EXPECT_EQ(f.result.fusion->time_offset, 0.0);
    EXPECT_FALSE(f.result.fusion->antenna_offset_estimated) << "seed " << seed;
    EXPECT_LE(f.trajectory.rmse, kSlack * 0.017) << "seed " << seed;  // recorded 0.017 m
    EXPECT_LE(f.map.all.rmse, kSlack * 0.190) << "seed " << seed;     // recorded 0.190 m
    EXPECT_LT(f.map.all.rmse, p.map.all.rmse) << "seed " << seed;
  }
}

}  // namespace
}  // namespace flexcloud
