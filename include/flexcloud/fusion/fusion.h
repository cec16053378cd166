#pragma once
// Robust fusion of the SLAM trajectory and the GNSS into one estimate of the true trajectory,
// before any control point is chosen. The SLAM is right locally and wrong globally; the GNSS is
// right globally and wrong locally, sometimes badly and sometimes while claiming to be good.
//
// A pose graph over keyframes of the SLAM trajectory (Ceres Solver): each keyframe has a pose in
// ENU and a drift state (rotation rate per metre and scale error) that changes slowly; the SLAM
// relative motion between keyframes is a factor whose noise grows with the path; each fix is a
// factor on the antenna position (the pose at the fix's stamp, the lever arm applied) weighted
// by its std-dev, under a redescending loss (Geman-McClure) whose scale shrinks stage by stage
// (graduated non-convexity), so clusters of false RTK fixes lose their pull. The GNSS clock
// offset is a parameter of the problem; std-devs the receiver does not give are estimated from
// the residuals.

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "flexcloud/cancel.h"
#include "flexcloud/fusion/clock_offset.h"
#include "flexcloud/types.h"

namespace flexcloud {

/// Why a fix did not take part in, or was rejected by, the fusion.
enum class FixVerdict {
  kUsed,            ///< an inlier
  kOutlier,         ///< rejected by the robust loss: far from what SLAM and the other fixes say
  kAboveThreshold,  ///< its reported std-dev is above stddev_threshold
  kExcluded,        ///< in one of the excluded time ranges
  kOutsidePoses,    ///< outside the time span of the poses
};

std::string toString(FixVerdict v);

/// What became of one fix.
struct FixOutcome {
  double stamp = 0.0;  ///< GNSS clock, time offset of the parameters applied
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< ENU
  double residual = 0.0;  ///< m, from the fused antenna position (NaN where not fused)
  /// The fix less the fused antenna position, ENU, m (NaN where not fused).
  Eigen::Vector3d error = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Its own 1-sigma std-dev (reported, or estimated where not given; floored), ENU, m. For a
  /// fix that took no part: the reported one, NaN where none was given.
  Eigen::Vector3d std_dev = Eigen::Vector3d::Zero();
  /// Whether the std-dev came with the fix (from the receiver, or default_std_dev); false where
  /// the fusion estimated it.
  bool std_given = false;
  /// The SLAM's pose-to-pose error at its stamp (1-sigma, x = y horizontal, z vertical), m:
  /// added to std_dev in the fusion's weight of the fix.
  Eigen::Vector3d slam_jitter = Eigen::Vector3d::Zero();
  /// How little the SLAM's interpolation knows of where the vehicle was at its stamp (1-sigma,
  /// m; 0 at a pose's stamp, up to half the poses' distance in a long gap between them, as at
  /// a stop of a SLAM that keeps a pose every few metres): added to std_dev as well.
  double slam_gap = 0.0;
  double weight = 0.0;  ///< final weight of the robust loss, 0..1
  /// Precise by its std-dev, but its neighbours and it scatter more than that claims: it took no
  /// part in the refinement by precise fixes (precise_follow.h).
  bool rough = false;
  /// Its height took no part: a code-grade fix the graph rejected that was apart from it in
  /// height alone (apartInHeightAlone()).
  bool height_left_out = false;
  FixVerdict verdict = FixVerdict::kUsed;

  /// Its std-dev with the SLAM's jitter and interpolation at its stamp, per axis, as the fusion
  /// weighs it.
  Eigen::Vector3d weighedSigma() const;
};

/// Sigmas within which a fix counts as agreeing with the fused trajectory horizontally.
constexpr double kHeightApart = 3.0;

/// Whether a fix `error` (m, ENU) off the fused trajectory, weighed with `sigma` (per axis),
/// lies within kHeightApart of its sigmas of it horizontally and beyond them in height: a SLAM
/// whose height drifts parts from good fixes so. False where either is not finite.
bool apartInHeightAlone(const Eigen::Vector3d& error, const Eigen::Vector3d& sigma);

/// m: an antenna offset from the poses' origin (estimated where no lever arm is given) beyond
/// this is applied and told of; a smaller one is held at 0 (KITTI's LiDAR odometry, its truth
/// within 0.1 m of the LiDAR: estimated at 0.45 m at most).
constexpr double kNotableAntenna = 0.5;

struct FusionResult {
  /// The fused pose (ENU, body frame) at every pose of the input, in the same order.
  Trajectory poses;
  std::vector<FixOutcome> fixes;
  /// Clock offset estimated on top of params.gnss_time_offset, s (SLAM time = GNSS time +
  /// offset: a fix stamped t was taken at SLAM time t + offset).
  double time_offset = 0.0;
  /// Whether the offset was estimated: asked for (max_time_offset > 0) and told from 0 by the
  /// speed and heading profiles of the SLAM and the GNSS (otherwise it stays 0), its 1-sigma
  /// (the profiles' together, s; infinite where not estimated), and what the speed profiles
  /// alone showed with their 1-sigma (infinite where the speed varied too little).
  bool time_offset_estimated = false;
  double time_offset_sigma = 0.0;
  double time_offset_from_speed = 0.0;
  double time_offset_speed_sigma = 0.0;
  /// The speed and heading profiles' offsets and what they say together (clock_offset.h):
  /// `clock.observable` false keeps the stamps as given, and clock.reason says why.
  ClockEstimate clock;
  /// Where the fit of positions took the offset (time_offset_from_positions) beyond two of the
  /// speed profiles' sigmas from theirs, the offset is held at theirs (at 0 where theirs lies
  /// within three of their sigmas of it): a SLAM shape error (fast turns) passes for a clock
  /// offset in a fit of positions, never in the speed profiles.
  bool time_offset_held = false;
  double time_offset_from_positions = 0.0;
  Eigen::Vector3d lever_arm = Eigen::Vector3d::Zero();  ///< applied, body frame, m
  /// Where no lever arm was given: the antenna's offset from the poses' origin the drive shows
  /// (body forward, left; m). The poses are then the antenna's, as without the estimate.
  Eigen::Vector2d antenna_offset = Eigen::Vector2d::Zero();
  bool antenna_offset_estimated = false;
  double antenna_offset_sigma = 0.0;  ///< m, 1-sigma along the body's direction of travel
  /// The 1-sigma std-devs given to fixes without one: estimated from the residuals (NaN when
  /// every fix had its own).
  double estimated_std_h = 0.0;
  double estimated_std_v = 0.0;
  /// Median std-dev the fused fixes were weighted with (horizontal, m).
  double median_std_h = 0.0;
  /// Factor the slam_*_noise parameters were multiplied with (1: as given). It grows when the
  /// fused trajectory stays further from the GNSS's inliers than their own noise allows: a SLAM
  /// that drifts more than its noise parameters say.
  double slam_noise_scale = 1.0;
  /// Factors on the reported std-devs of the fixes by class of their horizontal std-dev: below
  /// 5 cm (RTK-fixed), below 50 cm (float), above; from the drive (1: as reported).
  double reported_std_scale[3] = {1.0, 1.0, 1.0};
  /// Upper bound of the GNSS's horizontal white noise from its own roughness, m.
  double gnss_roughness_h = 0.0;
  /// The white noise of the fixes without a std-dev (horizontal, vertical; m; NaN without
  /// such fixes): the smaller of two bounds from the lower quartile of their third differences
  /// (calmRoughness), of their track (the motion's jerk adds to it) and of their track less the
  /// SLAM (its jitter adds to it). No fit is involved.
  Eigen::Vector2d unknown_white =
      Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// The SLAM's pose-to-pose error at the inliers (median, 1-sigma, m).
  double slam_jitter_h = 0.0;
  double slam_jitter_v = 0.0;
  /// The refinement by precise fixes (precise_follow.h): per pose whether the SLAM jumped at
  /// it (its shape there is no better than its position), how many poses moved by more than a
  /// millimetre, the largest move.
  std::vector<bool> jumped;
  /// rad per pose, about ENU up: how far that refinement turned its heading with the path the
  /// fixes moved it onto (0 where it did not; precise_follow.h).
  std::vector<double> heading_turn;
  std::size_t detail_poses = 0;
  double detail_max_shift = 0.0;
  /// What that refinement learned: the fixes that took part, the SLAM's short-term error
  /// (random walk intensity, m^2 per m of path, horizontal and vertical), its excess over the
  /// fixes' noise (m), the steps taken for jumps, the fixes the graph had rejected that it
  /// took back, those it kept out as too far for an error of the SLAM (the GNSS showing a
  /// fault at their edge), and those it rejected; and the stretches where it followed fixes
  /// that claim precision and agree with each other however far the SLAM's shape lay from them
  /// (the SLAM failing there): their first and last fix's instant (SLAM clock, s), how many
  /// fixes, and how far at most the keyframe graph's trajectory lay from them (m); the
  /// precision they showed (m: the largest std-dev claimed, or for fixes without one the white
  /// noise measured from such fixes) and whether every fix claimed its own.
  struct SlamFailure {
    double begin = 0.0, end = 0.0, worst = 0.0, precision = 0.0;
    std::size_t fixes = 0;
    bool claimed = true;
  };
  struct Follow {
    std::size_t fixes = 0;
    double q_h = 0.0;
    double q_v = 0.0;
    double excess = 0.0;
    std::size_t jumps = 0;
    std::size_t taken_back = 0;
    std::size_t locked = 0;
    std::size_t rejected = 0;
    std::vector<SlamFailure> slam_failures;
  } follow;
  /// The runs of code-grade fixes at the drive's first or last fixes that were followed against
  /// the SLAM's shape (drive_ends.h): their first and last fix's instant (SLAM clock, s), how
  /// many, how far the result lay from them before (m, their mean error) and their white noise
  /// (m, horizontal 1-sigma as weighed).
  std::vector<SlamFailure> drive_ends_followed;
  std::size_t keyframes = 0;
  std::size_t used = 0;
  std::size_t heights_left_out = 0;  ///< of those used, those with their horizontal part alone
  std::size_t outliers = 0;
  std::size_t above_threshold = 0;
  std::size_t excluded = 0;
  std::size_t outside = 0;
  int stages = 0;  ///< robust-loss stages solved
  /// Ceres solves of the stages: one each, two where the offset left max_time_offset and the
  /// stage was solved again with it held at the bound.
  int solves = 0;
  double seconds = 0.0;
};

/// The numbers the fusion uses; fusionOptions() (params.h) fills them from the parameter table.
struct FusionOptions {
  double keyframe_spacing = 0.0;        ///< m of path between the keyframes estimated
  double slam_rotation_noise = 0.0;     ///< deg/sqrt(km), random rotation error of the SLAM
  double slam_translation_noise = 0.0;  ///< m/sqrt(km)
  double slam_drift_noise = 0.0;        ///< deg/km/sqrt(km), change of the rotation drift rate
  double slam_scale_noise = 0.0;        ///< %/sqrt(km), change of the scale error
  double gnss_std_floor = 0.0;          ///< m, the smallest std-dev a fix is weighted with
  double outlier_threshold = 0.0;       ///< sigma, scale of the robust loss
  double max_time_offset = 0.0;         ///< s, the largest GNSS clock offset estimated
  double max_slam_noise_scale = 0.0;    ///< largest factor the SLAM noise is raised by
  Eigen::Vector3d lever_arm = Eigen::Vector3d::Zero();  ///< m, the antenna in the body frame
  double stddev_threshold = 0.0;           ///< m, reported std-devs above it are not taken as given
  std::vector<TimeRange> excluded_ranges;  ///< stamps whose fixes take no part
  int threads = 0;                         ///< solver threads; 0: all cores
};

/// The indices of the fixes of `f` that took part in the fusion (used or rejected), by stamp.
std::vector<std::size_t> judgedByStamp(const FusionResult& f);

/// Fuses `poses` (SLAM, map frame, sorted by stamp) with `gnss` (ENU, sorted by stamp, std-dev
/// NaN where not given), starting from the rigid alignment T_enu_map, then refines it by the
/// precise fixes (followPreciseGnss) and follows the drive's ends (followTheDrivesEnds). Throws
/// Error when fewer than 3 fixes can take part, or when cancelled.
FusionResult fuseTrajectory(const Trajectory& poses, const std::vector<GnssPoint>& gnss,
                            const Eigen::Isometry3d& T_enu_map, const FusionOptions& options,
                            const CancelToken& cancel = neverCancelled());

}  // namespace flexcloud
