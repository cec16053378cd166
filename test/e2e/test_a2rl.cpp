// The real drive of ../shared/data/a2rl against the published method's accuracy on it.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <utility>
#include <vector>

#include "flexcloud/fusion/clock_offset.h"
#include "flexcloud/georeference.h"
#include "flexcloud/io/text_io.h"
#include "real_drive.h"
#include "real_drives.h"

namespace flexcloud {
namespace {

std::string findData() { return test::findRealDrive("a2rl"); }

struct Published {
  int control_points;
  double mae, std, max;
};

// The published method on this drive (all 2386 poses; ../shared/data/a2rl/README.md).
constexpr Published kPublished[] = {{10, 2.84, 2.36, 17.61},
                                    {50, 0.87, 2.09, 17.04},
                                    {100, 0.39, 0.90, 10.87},
                                    {200, 0.23, 0.41, 7.44}};

DriveInput load(const std::string& dir) { return study::loadRealDrive(dir); }

/// Every test reads the drive; without it they are skipped with a message.
class A2rl : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string dir = findData();
    if (dir.empty())
      GTEST_SKIP() << "a2rl data not found (../shared/data/a2rl beside the repository, or set "
                      "FLEXCLOUD_DATA_DIR); skipped";
    drive_ = load(dir);
  }
  DriveInput drive_;
};

/// The file gives no std-devs (0): the fusion estimates them; the GNSS control points take the
/// publisher's word (RTK, 1 cm). Everything else is the defaults, which estimate the clock
/// offset between the SLAM's stamps and the GNSS's (TheSlamStampsLagTheGnssByATenthOfASecond).
Params forThisData(bool fusion) {
  Params p;
  p.fusion = fusion;
  if (!fusion) {
    p.default_std_dev = 0.01;
    p.max_time_offset = 0.0;  // the published method's way: the GNSS at the stamps as given
  }
  return p;
}

/// With the GNSS at the poses as control points (the published method's way, fusion off),
/// flexcloud's spread and refinement beat the published figures on every measure.
TEST_F(A2rl, BeatsThePublishedMethodAtEveryControlPointCount) {
  const DriveInput& in = drive_;
  ASSERT_EQ(in.poses.size(), 2386u);
  for (const Published& pub : kPublished) {
    Params p = forThisData(false);
    p.control_points = pub.control_points;
    const GeoreferenceResult r = georeference(in, p);
    const ErrorStats& m = r.metrics_rubbersheet;
    std::printf(
        "a2rl %3d control points: MAE %.3f STD %.3f MAX %.3f m (published %.2f %.2f %.2f)\n",
        pub.control_points, m.mae, m.std, m.max, pub.mae, pub.std, pub.max);
    EXPECT_EQ(r.control_points.points.size(), static_cast<std::size_t>(pub.control_points));
    EXPECT_LE(m.mae, pub.mae) << pub.control_points;
    EXPECT_LE(m.std, pub.std) << pub.control_points;
    EXPECT_LE(m.max, pub.max) << pub.control_points;
    EXPECT_EQ(r.poses_matched, 2386u);  // every pose is evaluated
    // The rigid alignment alone is far off, as the data's README says (MAE 7.14 m).
    EXPECT_NEAR(r.metrics_aligned.mae, 7.2, 0.3);
  }
}

/// The stretch of the drive where the fusion and the GNSS disagree (doc/ACCURACY.md).
constexpr std::size_t kDisputedBegin = 306, kDisputedEnd = 359;

/// The file gives no std-devs: no warning says a stretch claimed RTK precision, and the
/// disputed stretch, where the fusion leaves out fixes up to 17 m off, is named as one whose
/// fixes came without a std-dev (the SLAM is not blamed, nor the GNSS convicted). The fixes
/// 0.4-0.7 m from the SLAM at 38-55 s, measured within 1-3 cm, are followed, and the warning
/// names the SLAM's failure without saying they claimed a precision.
TEST_F(A2rl, TheDisputedStretchIsNamedWithoutAClaimOfPrecision) {
  const GeoreferenceResult r = georeference(drive_, forThisData(true));
  const double begin = drive_.poses[kDisputedBegin].stamp, end = drive_.poses[kDisputedEnd].stamp;
  bool named = false, failure = false;
  for (const std::string& w : resultWarnings(r, Params{}, nullptr)) {
    EXPECT_EQ(w.find("claimed RTK precision"), std::string::npos) << w;
    EXPECT_EQ(w.find("that claim RTK precision"), std::string::npos) << w;
    if (w.rfind("SLAM failure: ", 0) == 0) {
      failure = w.find("no std-dev given") != std::string::npos &&
                w.find("37.8-54.5 s into the drive") != std::string::npos;
    }
    if (w.rfind("GNSS from ", 0) != 0 || w.find("no std-dev given") == std::string::npos) continue;
    char* rest = nullptr;
    const double a = std::strtod(w.c_str() + 10, &rest);
    const double b = std::strtod(rest + 4, nullptr);  // past " to "
    std::printf("named: %.1f-%.1f s after the first pose (disputed stretch %.1f-%.1f s)\n",
                a - drive_.poses.front().stamp, b - drive_.poses.front().stamp,
                begin - drive_.poses.front().stamp, end - drive_.poses.front().stamp);
    named = named || (a < end && b > begin);
  }
  EXPECT_TRUE(named);
  EXPECT_TRUE(failure);
}

/// Size of the third difference of the horizontal positions at i (m): what stays of a track
/// once its position, speed and acceleration are taken out. Measured positions carry noise
/// there; a curve drawn through an outage does not.
double thirdDifference(const std::vector<Eigen::Vector3d>& x, std::size_t i) {
  const Eigen::Vector3d d = x[i + 2] - 3.0 * x[i + 1] + 3.0 * x[i] - x[i - 1];
  return d.head<2>().norm();
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// The positions of the drive's GNSS and of its SLAM poses, row by row.
std::pair<std::vector<Eigen::Vector3d>, std::vector<Eigen::Vector3d>> tracksOf(
    const DriveInput& in) {
  std::vector<Eigen::Vector3d> gnss, slam;
  for (const auto& g : in.local_gnss) gnss.push_back(g.position);
  for (const auto& p : in.poses) slam.push_back(p.position);
  return {gnss, slam};
}

/// The GNSS of the disputed stretch is far smoother than anywhere else on the drive, while the
/// SLAM's is not: the mark of positions interpolated through an outage (the file's GNSS was
/// resampled at the pose stamps by its publisher), not of fixes measured there.
TEST_F(A2rl, TheDisputedGnssStretchIsSmootherThanMeasuredFixes) {
  const DriveInput& in = drive_;
  const auto [gnss, slam] = tracksOf(in);
  std::vector<double> gnss_in, gnss_out, slam_in, slam_out;
  for (std::size_t i = 1; i + 2 < gnss.size(); ++i) {
    const bool disputed = i >= kDisputedBegin && i < kDisputedEnd;
    (disputed ? gnss_in : gnss_out).push_back(thirdDifference(gnss, i));
    (disputed ? slam_in : slam_out).push_back(thirdDifference(slam, i));
  }
  std::printf(
      "a2rl third difference, median (m): GNSS %.4f in poses %zu-%zu, %.4f elsewhere; SLAM "
      "%.4f and %.4f\n",
      median(gnss_in), kDisputedBegin, kDisputedEnd - 1, median(gnss_out), median(slam_in),
      median(slam_out));
  EXPECT_LT(median(gnss_in), 0.25 * median(gnss_out));
  EXPECT_GT(median(slam_in), 0.5 * median(slam_out));
}

/// Speed (m/s) from point i to i + 1 of a track stamped like the poses (3D: the SLAM's tilt
/// does not change it).
double stepSpeed(const std::vector<Eigen::Vector3d>& x, const Trajectory& poses, std::size_t i) {
  return (x[i + 1] - x[i]).norm() / (poses[i + 1].stamp - poses[i].stamp);
}

/// In the disputed stretch the car cannot have had both speeds: the SLAM keeps the 5.2-5.4 m/s
/// it had before (4.8-5.6) while the GNSS slows to 3.8 and speeds up to 6.0 m/s, falling up to
/// 8.7 m behind along the track and catching up. Their speeds part there by 0.77 m/s in the
/// median against 0.04 elsewhere: the GNSS of the stretch is not what the car did.
TEST_F(A2rl, TheDisputedGnssStretchHasASpeedTheSlamDoesNot) {
  const DriveInput& in = drive_;
  const auto [gnss, slam] = tracksOf(in);
  std::vector<double> apart_in, apart_out, slam_in, gnss_in;
  double behind = 0.0, most_behind = 0.0;
  for (std::size_t i = 0; i + 1 < gnss.size(); ++i) {
    if (in.poses[i + 1].stamp - in.poses[i].stamp > 1.0) continue;  // a stop
    const double vs = stepSpeed(slam, in.poses, i), vg = stepSpeed(gnss, in.poses, i);
    const bool disputed = i >= kDisputedBegin && i + 1 < kDisputedEnd;
    (disputed ? apart_in : apart_out).push_back(std::abs(vs - vg));
    if (!disputed) continue;
    slam_in.push_back(vs);
    gnss_in.push_back(vg);
    behind += (vs - vg) * (in.poses[i + 1].stamp - in.poses[i].stamp);
    most_behind = std::max(most_behind, behind);
  }
  const auto [slam_lo, slam_hi] = std::minmax_element(slam_in.begin(), slam_in.end());
  const auto [gnss_lo, gnss_hi] = std::minmax_element(gnss_in.begin(), gnss_in.end());
  std::printf(
      "a2rl speeds in poses %zu-%zu: SLAM %.2f-%.2f m/s, GNSS %.2f-%.2f m/s (up to %.1f m "
      "behind); |SLAM - GNSS| median %.3f m/s there, %.3f elsewhere\n",
      kDisputedBegin, kDisputedEnd - 1, *slam_lo, *slam_hi, *gnss_lo, *gnss_hi, most_behind,
      median(apart_in), median(apart_out));
  EXPECT_GT(*slam_lo, 4.5);  // the SLAM keeps its speed
  EXPECT_LT(*gnss_lo, 4.0);  // the GNSS slows down ...
  EXPECT_GT(*gnss_hi, 5.8);  // ... and speeds up
  EXPECT_GT(most_behind, 5.0);
  EXPECT_GT(median(apart_in), 10.0 * median(apart_out));
}

/// Poses within `reach` poses of a stop: a gap of more than a second between two poses (this
/// SLAM's poses are keyframes by distance, so a stop shows as a long gap).
std::vector<bool> nearStops(const Trajectory& poses, std::size_t reach) {
  std::vector<bool> near(poses.size(), false);
  for (std::size_t i = 0; i + 1 < poses.size(); ++i) {
    if (poses[i + 1].stamp - poses[i].stamp <= 1.0) continue;
    const std::size_t lo = i > reach ? i - reach : 0;
    for (std::size_t k = lo; k <= std::min(poses.size() - 1, i + reach); ++k) near[k] = true;
  }
  return near;
}

/// A least-squares slope through the origin, and the RMS of y before and after it is taken out.
struct Slope {
  double slope = 0.0, rms_before = 0.0, rms_after = 0.0;
};

Slope fitSlope(const std::vector<double>& x, const std::vector<double>& y) {
  double xy = 0.0, xx = 0.0, yy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i)
    xy += x[i] * y[i], xx += x[i] * x[i], yy += y[i] * y[i];
  Slope s;
  s.slope = xy / xx;
  const auto n = static_cast<double>(x.size());
  s.rms_before = std::sqrt(yy / n);
  s.rms_after = std::sqrt(std::max(0.0, yy - s.slope * xy) / n);
  return s;
}

/// This drive's SLAM stamps lag its GNSS by about a tenth of a second (one scan of a 10 Hz
/// LiDAR), which the fusion's defaults estimate. Shown without flexcloud's clock code: over
/// every window of 21 poses the SLAM is fitted rigidly to the GNSS (Eigen's umeyama), and the
/// residual along the track at the middle pose is compared with how much faster than the
/// window's mean the car goes there. An offset dt puts the GNSS v dt ahead of the SLAM, less
/// the window's mean: the slope is dt, the same at every speed, and taking it out halves the
/// residual. The speed profiles (estimateClockOffset) must agree with it.
TEST_F(A2rl, TheSlamStampsLagTheGnssByATenthOfASecond) {
  const DriveInput& in = drive_;
  const std::vector<GnssPoint>& g = in.local_gnss;
  constexpr double kBands[] = {0.0, 6.0, 12.0, 1e9};  // m/s
  std::vector<double> dv[3], along[3], dv_all, along_all;
  for (const study::LagSample& l : study::lagSamples(in)) {
    const int band = l.speed < kBands[1] ? 0 : l.speed < kBands[2] ? 1 : 2;
    dv[band].push_back(l.speed_change);
    along[band].push_back(l.along);
    dv_all.push_back(l.speed_change);
    along_all.push_back(l.along);
  }
  const Slope all = fitSlope(dv_all, along_all);
  for (int b = 0; b < 3; ++b) {
    const Slope s = fitSlope(dv[b], along[b]);
    std::printf(
        "a2rl GNSS ahead of the SLAM, speeds %.0f-%.0f m/s (%zu poses): %.3f s; residual along "
        "the track %.3f -> %.3f m RMS\n",
        kBands[b], std::min(kBands[b + 1], 99.0), dv[b].size(), s.slope, s.rms_before, s.rms_after);
    EXPECT_NEAR(s.slope, 0.095, 0.015) << "band " << b;  // 0.088, 0.102, 0.097 s
    if (b > 0) {
      EXPECT_LT(s.rms_after, 0.7 * s.rms_before) << "band " << b;
    }
  }
  const ClockOffsetEstimate speed = estimateClockOffset(in.poses, g, 1.0);
  std::printf("  all poses: %.3f s; the speed profiles: %.4f s (1-sigma %.4f s)\n", all.slope,
              speed.offset, speed.sigma);
  EXPECT_TRUE(speed.observable);
  EXPECT_NEAR(speed.offset, all.slope, 0.01);
  EXPECT_LT(speed.sigma, 0.01);
  // What flexcloud_accuracy scores the drive at: the fit without its outliers (the disputed
  // stretch, the stops), as the fast poses alone give it.
  const double lag = study::lagOf(study::lagSamples(in));
  std::printf("  without its outliers: %.4f s\n", lag);
  EXPECT_NEAR(lag, 0.097, 0.003);
}

/// The position of `track` at time t, linear between its poses; none outside its span.
std::optional<Eigen::Vector3d> positionAt(const Trajectory& track, double t) {
  const auto it = std::lower_bound(track.begin(), track.end(), t,
                                   [](const Pose& p, double s) { return p.stamp < s; });
  if (it == track.end() || (it == track.begin() && it->stamp != t)) return std::nullopt;
  if (it->stamp == t) return it->position;
  const Pose& a = *(it - 1);
  const double f = (t - a.stamp) / (it->stamp - a.stamp);
  return a.position + f * (it->position - a.position);
}

/// Deviations (m) of a trajectory (SLAM clock) from the held-out fixes (every 10th), each taken
/// at the fix's true instant: the trajectory at SLAM time stamp + the drive's lag. Split into all
/// of them, those outside the disputed stretch, and of those the ones within 8 poses of a stop and
/// away.
struct HeldOut {
  std::vector<double> all, outside, near_stops, away;
};

HeldOut heldOut(const DriveInput& drive, const Trajectory& track, double lag) {
  const std::vector<bool> near = nearStops(drive.poses, 8);
  HeldOut h;
  for (std::size_t i = 5; i < drive.local_gnss.size(); i += 10) {
    const GnssPoint& fix = drive.local_gnss[i];
    const auto at = positionAt(track, fix.stamp + lag);
    if (!at) continue;
    const double d = (*at - fix.position).norm();
    h.all.push_back(d);
    if (i >= kDisputedBegin && i < kDisputedEnd) continue;
    h.outside.push_back(d);
    (near[i] ? h.near_stops : h.away).push_back(d);
  }
  return h;
}

/// Prints the held-out figures of one run; returns those outside the disputed stretch.
ErrorStats report(const char* what, const HeldOut& h) {
  const ErrorStats a = errorStats(h.all), o = errorStats(h.outside);
  const ErrorStats n = errorStats(h.near_stops), w = errorStats(h.away);
  std::printf(
      "a2rl 200 control points, %s: held-out fixes MAE %.3f MAX %.3f m; outside poses %zu-%zu "
      "MAE %.3f STD %.3f MAX %.3f m (within 8 poses of a stop %.3f / %.3f, away %.3f / %.3f)\n",
      what, a.mae, a.max, kDisputedBegin, kDisputedEnd - 1, o.mae, o.std, o.max, n.mae, n.max,
      w.mae, w.max);
  return o;
}

/// Leave-out validation (no truth exists here): every 10th fix is held out of the run, and the
/// rubber-sheeted trajectory is compared with it at the fix's true instant, the drive's lag read
/// from its shape alone (TheSlamStampsLagTheGnssByATenthOfASecond), whatever clock a method
/// chose: a wrong clock shows as an error along the track. The fusion (defaults) against the
/// GNSS control points (the published method's way), with and without the clock offset.
TEST_F(A2rl, LeaveOutDeviation) {
  const DriveInput& all = drive_;
  DriveInput in = all;
  in.local_gnss.clear();
  for (std::size_t i = 0; i < all.local_gnss.size(); ++i) {
    if (i % 10 != 5) in.local_gnss.push_back(all.local_gnss[i]);
  }
  const GeoreferenceResult r = georeference(in, forThisData(true));
  // Its poses jitter by 7 mm, below a centimetre: not worth smoothing (its fixes, resampled at
  // the poses' stamps, share a fifth of it).
  EXPECT_LT(r.jitter.white, 0.01);
  EXPECT_EQ(r.jitter.half_width, 0);
  const FusionResult& f = *r.fusion;
  const double dt = f.time_offset;
  const double lag = study::lagOf(study::lagSamples(all));
  const HeldOut h = heldOut(all, r.rubbersheet, lag);
  const ErrorStats o = report("fusion (defaults)", h);
  const HeldOut fused = heldOut(all, f.poses, lag);
  const ErrorStats ft = report("fusion (defaults), the fused trajectory", fused);
  std::printf(
      "  clock offset %.4f s (speed profiles %.4f, 1-sigma %.4f), SLAM noise x%.2f, GNSS "
      "roughness bound %.4f m, %zu fixes used, %zu outliers, SLAM jitter (median) %.3f m "
      "horizontal %.3f m vertical, %zu precise fixes (excess %.3f m, %zu taken back)\n",
      dt, f.time_offset_from_speed, f.time_offset_sigma, f.slam_noise_scale, f.gnss_roughness_h,
      f.used, f.outliers, f.slam_jitter_h, f.slam_jitter_v, f.follow.fixes, f.follow.excess,
      f.follow.taken_back);
  EXPECT_GE(h.all.size(), 238u);  // of 239: the last lies past the poses' end
  EXPECT_TRUE(f.time_offset_estimated);
  EXPECT_FALSE(f.time_offset_held);  // the fit of positions and the speed profiles agree
  EXPECT_NEAR(dt, 0.095, 0.015);
  // The 1-sigma is the profiles' together, with what a SLAM's own lag adds (clock_offset.h).
  EXPECT_GE(f.time_offset_sigma, kClockSystematic);
  EXPECT_LT(f.time_offset_sigma, 0.01);
  EXPECT_TRUE(std::isfinite(f.estimated_std_h));  // the file gives no std-devs
  EXPECT_LT(f.gnss_roughness_h, 0.02);            // RTK: a centimetre at most
  // This SLAM's z jitters from pose to pose (doc/ACCURACY.md): a tenth of a metre.
  EXPECT_GT(f.slam_jitter_v, 0.05);
  EXPECT_LT(f.slam_jitter_h, 0.02);

  // The published method's way: GNSS at the pose stamps as control points.
  const GeoreferenceResult g = georeference(in, forThisData(false));
  const ErrorStats go = report("GNSS control points", heldOut(all, g.rubbersheet, lag));
  // The same with the fusion's offset given: the offset serves every method.
  Params given = forThisData(false);
  given.gnss_time_offset = dt;
  const GeoreferenceResult gd = georeference(in, given);
  const ErrorStats gdo =
      report("GNSS control points, the clock offset given", heldOut(all, gd.rubbersheet, lag));
  EXPECT_LT(gdo.mae, go.mae);
  EXPECT_LT(gdo.max, go.max);
  // Without the fusion the speed profiles show the offset as well, and the simple way applies
  // it (0.0952 +- 0.0025 s): as good as given by hand.
  Params simple = forThisData(false);
  simple.max_time_offset = Params().max_time_offset;
  const GeoreferenceResult gs = georeference(in, simple);
  EXPECT_TRUE(std::isfinite(gs.clock_offset_sigma));  // applied
  EXPECT_NEAR(gs.clock_offset, dt, 0.01);
  const ErrorStats gso =
      report("fusion: false, the speed profiles' clock offset", heldOut(all, gs.rubbersheet, lag));
  EXPECT_LT(gso.mae, go.mae);  // 0.114 against 1.210 m (outside the disputed stretch)
  EXPECT_LT(gso.max, go.max);  // 0.455 against 1.600 m

  // Outside the disputed stretch the defaults beat the published method's way (GNSS control
  // points at the stamps as given, 1.210 / 1.600 m) and the simple way with the speed profiles'
  // clock (0.114 / 0.455 m) in MAE and MAX: 0.080 / 0.429 m (doc/ACCURACY.md, the real drives).
  // At 38-55 s the fixes, without a std-dev but measured within 1-3 cm, lie 0.4-0.7 m from the
  // SLAM and agree with each other: they are followed (kept out, the fused trajectory was 0.52 m
  // off a held-out fix there, and the defaults 0.088 / 0.498 m).
  EXPECT_LT(o.mae, 0.09);
  EXPECT_LT(o.mae, go.mae);
  EXPECT_LT(o.max, go.max);
  EXPECT_LT(o.mae, gso.mae);
  EXPECT_LT(o.max, gso.max);
  EXPECT_LT(ft.mae, 0.08);
  // The stops do not stand out (within 8 poses of one 0.171 / 0.416 m, away 0.100 / 0.564 m):
  // where the car speeds up or slows down, a clock off shows most.
  EXPECT_LT(errorStats(h.near_stops).max, 0.55);  // 0.416 m

  // The offset is what moved them: the fusion without it (max_time_offset 0).
  Params fixed = forThisData(true);
  fixed.max_time_offset = 0.0;
  const GeoreferenceResult z = georeference(in, fixed);
  const HeldOut zh = heldOut(all, z.rubbersheet, lag);
  report("fusion, no clock offset", zh);
  EXPECT_GT(errorStats(zh.near_stops).mae, 2.0 * errorStats(h.near_stops).mae);  // 1.03, 0.17
}

}  // namespace
}  // namespace flexcloud
