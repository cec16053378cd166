// The refinement by precise fixes (precise_follow.h), on known answers: a fused trajectory
// along a straight road whose SLAM errs in a known way, and fixes on the true road.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "flexcloud/fusion/precise_follow.h"

namespace flexcloud {
namespace {

using Vec3 = Eigen::Vector3d;

/// The true road: x = 1 m per pose, 10 Hz. The fused trajectory is the truth plus `slam(i)`;
/// a fix at every pose's instant, the truth plus white noise of `noise` per axis, weighted by
/// the graph with `weight(i)`.
template <typename Slam, typename Weight>
FusionResult road(std::size_t n, double noise, const Slam& slam, const Weight& weight,
                  unsigned seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  FusionResult f;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = static_cast<double>(i);
    Pose p;
    p.stamp = 0.1 * x;
    p.position = Vec3(x, 0.0, 0.0) + slam(i);
    f.poses.push_back(p);
    FixOutcome o;
    o.stamp = p.stamp;
    o.position = Vec3(x, 0.0, 0.0) + noise * Vec3(n01(rng), n01(rng), 2.0 * n01(rng));
    o.std_dev = Vec3(noise, noise, 2.0 * noise);
    o.std_given = true;
    o.weight = weight(i);
    o.verdict = o.weight >= 0.5 ? FixVerdict::kUsed : FixVerdict::kOutlier;
    f.fixes.push_back(o);
  }
  return f;
}

/// The largest horizontal distance of the fused poses [lo, hi) from the true road.
double worst(const FusionResult& f, std::size_t lo, std::size_t hi) {
  double w = 0.0;
  for (std::size_t i = lo; i < hi; ++i) {
    const Vec3 d = f.poses[i].position - Vec3(static_cast<double>(i), 0.0, 0.0);
    w = std::max(w, d.head<2>().norm());
  }
  return w;
}

std::size_t rejected(const FusionResult& f) {
  std::size_t n = 0;
  for (const auto& o : f.fixes) n += o.verdict == FixVerdict::kOutlier;
  return n;
}

// A real LiDAR odometry's errors of a few centimetres, and a jump of half a metre between two
// scans that it carries for two seconds: the graph rejected the fixes there, every one of them
// is taken back and the poses follow them.
TEST(PreciseFollow, TheSlamJumpedAndTheFixesAreTakenBack) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<Vec3> wander(600);
  for (auto& w : wander) w = 0.02 * Vec3(n01(rng), n01(rng), 0.0);
  auto slam = [&](std::size_t i) -> Vec3 {
    return wander[i] + (i >= 300 && i < 320 ? Vec3(0.0, 0.5, 0.0) : Vec3::Zero());
  };
  FusionResult f =
      road(600, 0.02, slam, [](std::size_t i) { return i >= 300 && i < 320 ? 0.0 : 1.0; });
  ASSERT_GT(worst(f, 300, 320), 0.45);
  followPreciseGnss(f, FollowOptions{});
  EXPECT_LT(worst(f, 300, 320), 0.06);
  EXPECT_LT(worst(f, 0, 600), 0.08);
  EXPECT_EQ(rejected(f), 0u);
  EXPECT_EQ(f.follow.taken_back, 20u);
  EXPECT_GE(f.follow.jumps, 1u);
  EXPECT_GT(f.follow.excess, 0.01);
}

// A SLAM that errs only slowly, and a run of fixes 3 m off that claim 2 cm (multipath the
// graph rejected): it stays rejected and nothing follows it. A lone outlier among the good
// fixes is rejected as well.
TEST(PreciseFollow, AFarRunStaysRejectedAndALoneOutlierToo) {
  auto slam = [](std::size_t) -> Vec3 { return Vec3::Zero(); };
  FusionResult f =
      road(600, 0.02, slam, [](std::size_t i) { return i >= 200 && i < 260 ? 0.0 : 1.0; });
  for (std::size_t i = 200; i < 260; ++i) f.fixes[i].position.y() += 3.0;
  f.fixes[400].position.y() += 2.0;
  followPreciseGnss(f, FollowOptions{});
  EXPECT_LT(worst(f, 0, 600), 0.05);
  EXPECT_EQ(f.follow.locked, 60u);
  EXPECT_EQ(rejected(f), 61u);
  EXPECT_EQ(f.fixes[400].verdict, FixVerdict::kOutlier);
}

/// A SLAM that fails for 20 s (poses 200-399): it moves 2 m aside over 3 s, stays and comes
/// back, without a step, the graph rejecting the fixes there. The fixes came without a std-dev
/// (white noise 2 cm measured from them); in [200, 400) they are measured as elsewhere, or
/// (`drawn`) lie exactly on the road, as positions drawn through an outage do.
FusionResult failingSlamUnclaimedFixes(bool drawn) {
  auto slam = [](std::size_t i) -> Vec3 {
    const double x = static_cast<double>(i);
    const double in = std::clamp((x - 200.0) / 30.0, 0.0, 1.0);
    const double out = std::clamp((400.0 - x) / 30.0, 0.0, 1.0);
    return Vec3(0.0, 2.0 * std::min(in, out), 0.0);
  };
  FusionResult f =
      road(600, 0.02, slam, [](std::size_t i) { return i >= 210 && i < 390 ? 0.0 : 1.0; });
  f.unknown_white = Eigen::Vector2d(0.02, 0.04);
  for (std::size_t i = 0; i < f.fixes.size(); ++i) {
    f.fixes[i].std_given = false;
    if (drawn && i >= 200 && i < 400) f.fixes[i].position = Vec3(static_cast<double>(i), 0, 0);
  }
  return f;
}

// Fixes without a std-dev whose scatter shows 2 cm, the SLAM 2 m from them: they are
// followed, and the SLAM's failure is named as one whose fixes gave no std-dev. Drawn through
// an outage (far smoother than the rest), the same run stays out: the poses keep the SLAM's
// shape, less the correction its edges carry in.
TEST(PreciseFollow, MeasuredFixesWithoutAStdDevAreFollowedDrawnOnesNot) {
  FusionResult measured = failingSlamUnclaimedFixes(false);
  ASSERT_GT(worst(measured, 280, 320), 1.9);
  followPreciseGnss(measured, FollowOptions{});
  EXPECT_LT(worst(measured, 200, 400), 0.08);
  ASSERT_EQ(measured.follow.slam_failures.size(), 1U);
  EXPECT_FALSE(measured.follow.slam_failures[0].claimed);
  EXPECT_NEAR(measured.follow.slam_failures[0].precision, 0.02, 0.005);
  EXPECT_GT(measured.follow.slam_failures[0].worst, 1.5);

  FusionResult drawn = failingSlamUnclaimedFixes(true);
  followPreciseGnss(drawn, FollowOptions{});
  EXPECT_GT(worst(drawn, 280, 320), 1.0);  // the correction at its edges carried on: 1.4 m
  EXPECT_TRUE(drawn.follow.slam_failures.empty());
  EXPECT_GE(drawn.follow.locked, 100U);
}

// Fixes of 0.3 m see nothing of a SLAM that errs by centimetres: none takes part, nothing
// moves.
TEST(PreciseFollow, CodeGradeFixesTakeNoPart) {
  auto slam = [](std::size_t i) -> Vec3 { return Vec3(0.0, 0.05 * std::sin(0.1 * i), 0.0); };
  FusionResult f = road(600, 0.3, slam, [](std::size_t) { return 1.0; });
  const Trajectory before = f.poses;
  followPreciseGnss(f, FollowOptions{});
  EXPECT_EQ(f.follow.fixes, 0u);
  for (std::size_t i = 0; i < before.size(); ++i) {
    EXPECT_EQ(f.poses[i].position, before[i].position) << i;
  }
}

// A fix stamped t on the GNSS clock was taken at SLAM time t + time_offset: with the stamps
// moved by the offset, every pose moves as without.
TEST(PreciseFollow, TheClockOffsetPairsEachPoseWithItsFix) {
  auto slam = [](std::size_t i) -> Vec3 { return Vec3(0.0, 0.2 * std::sin(0.02 * i), 0.0); };
  auto all = [](std::size_t) { return 1.0; };
  FusionResult plain = road(600, 0.02, slam, all);
  FusionResult late = plain;
  late.time_offset = 0.35;
  for (auto& o : late.fixes) o.stamp -= 0.35;
  followPreciseGnss(plain, FollowOptions{});
  followPreciseGnss(late, FollowOptions{});
  for (std::size_t i = 0; i < plain.poses.size(); ++i) {
    EXPECT_NEAR(late.poses[i].position.y(), plain.poses[i].position.y(), 1e-9) << i;
  }
  EXPECT_LT(worst(plain, 0, 600), 0.03);
}

/// The heading of pose i (degrees about the vertical, 0 along the road).
double headingOf(const FusionResult& f, std::size_t i) {
  const Vec3 x = f.poses[i].orientation * Vec3::UnitX();
  return std::atan2(x.y(), x.x()) * 180.0 / M_PI;
}

// A graph whose heading went 1 degree off for 100 m and as far back for the next 100 m, its
// path with it (as where its keyframes could not follow the fixes): moved onto the fixes, the
// poses turn with their path, all but the part the SLAM's own short-term wander could explain
// (0.26 degrees here). Where only the fixes' noise moved the path, no pose turns.
TEST(PreciseFollow, ThePosesTurnAsTheirPathWasTurned) {
  const double off = 1.0 * M_PI / 180.0;
  auto lateral = [&](std::size_t i) -> double {
    const double x = static_cast<double>(i);
    if (i < 200 || i >= 400) return 0.0;
    return std::tan(off) * (i < 300 ? x - 200.0 : 400.0 - x);
  };
  auto slam = [&](std::size_t i) -> Vec3 { return Vec3(0.0, lateral(i), 0.0); };
  FusionResult f = road(600, 0.02, slam, [](std::size_t) { return 1.0; });
  for (std::size_t i = 200; i < 400; ++i) {
    const double yaw = i < 300 ? off : -off;
    f.poses[i].orientation = Eigen::AngleAxisd(yaw, Vec3::UnitZ());
  }
  ASSERT_NEAR(headingOf(f, 250), 1.0, 1e-9);
  followPreciseGnss(f, FollowOptions{});
  EXPECT_LT(worst(f, 0, 600), 0.05);
  for (std::size_t i : {240, 250, 260, 340, 350, 360}) EXPECT_NEAR(headingOf(f, i), 0.0, 0.35) << i;
  for (std::size_t i : {50, 100, 500, 550}) EXPECT_NEAR(headingOf(f, i), 0.0, 0.05) << i;
  // The turn is told per pose (the sheet places its points beside the route without it).
  ASSERT_EQ(f.heading_turn.size(), f.poses.size());
  EXPECT_NEAR(f.heading_turn[250] * 180.0 / M_PI, headingOf(f, 250) - 1.0, 1e-9);
}

}  // namespace
}  // namespace flexcloud
