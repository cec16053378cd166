#pragma once
// Real drives with a ground truth (doc/ACCURACY.md): a folder with poses_tum.txt (the SLAM),
// gt_tum.txt (the truth at the same stamps, in the frame of the GNSS) and gnss_rtk.txt /
// gnss_urban.txt (`stamp x y z sx sy sz`, std-devs 0 where not given), as
// ../shared/data/kitti_lo/NN and ../shared/data/mulran_lo/NAME hold them. A result is judged
// against the truth at the poses' true instants: row i of the trajectory against the truth at
// the stamp of pose i plus the drive's lag (0 for KITTI; MulRan's odometry leads or lags its
// truth rows by 38-58 ms, as its README gives), whatever clock a method chose or the stamps
// were shifted by.

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "flexcloud/georeference.h"
#include "flexcloud/sim/truth_metrics.h"

namespace flexcloud::study {

struct TruthDrive {
  std::string name;  ///< e.g. "07 rtk"
  DriveInput input;  ///< poses and local GNSS
  Trajectory truth;  ///< the truth rows, in the GNSS's frame, on the GNSS's clock
  /// The truth at every pose's true instant (its stamp plus `lag`), in the poses' order; NaN
  /// positions where that instant lies outside the truth rows.
  Trajectory truth_at_pose;
  double lag = 0.0;  ///< s: pose stamp s shows where the vehicle was at truth time s + lag
  /// How the poses' body is mounted on the truth's (knownMount), rotation vector, deg.
  Eigen::Vector3d mount = Eigen::Vector3d::Zero();
  double shift = 0.0;  ///< s the poses' (and the truth's) stamps were moved by
};

/// The lag of a drive's poses behind its truth rows (s, truth time - pose stamp), as the
/// dataset's README gives it: MulRan's six drives; 0 for any other folder (KITTI's).
double knownLag(const std::string& dir);

/// How the poses' body is mounted on the truth's, as a rotation vector about the truth's body
/// axes (deg): MulRan's truth is of its base, its poses of the LiDAR; 0 for any other folder
/// (KITTI's truth is of its poses' own frame).
Eigen::Vector3d knownMount(const std::string& dir);

/// The rotation of a drive's mount (TruthDrive::mount): the truth's body turned by it is the
/// poses' body.
Eigen::Matrix3d mountRotation(const TruthDrive& d);

/// The drive in `dir` with the GNSS of `kind` (rtk or urban), the poses' stamps moved by
/// `shift` seconds (a known clock offset: SLAM clock minus GNSS clock). Throws Error naming a
/// missing file or one whose rows do not pair with the poses'.
TruthDrive loadTruthDrive(const std::string& dir, const std::string& kind, double shift = 0.0);

/// A result against the truth (horizontal, m): RMSE and MAX over every pose, the MAX in the
/// drive's first and last 20 s and elsewhere; the fixes that took part in the fusion and how
/// many it rejected, and of those more than 3 m from the truth, how many it rejected; how far
/// the orientations turn from the truth.
struct TruthScore {
  double rmse = 0.0, max = 0.0, ends_max = 0.0, middle_max = 0.0;
  double turn_p95 = 0.0;  ///< deg: the 95th percentile of the orientations' angle from the truth
  /// The rotation from the truth's body to the orientations, constant over the drive (the mean
  /// of every pose's, projected onto the rotations), as a rotation vector about the truth's body
  /// axes (deg): the poses' mount on the truth's body, and any error of the orientations that
  /// stays the same over the drive.
  Eigen::Vector3d fitted_mount = Eigen::Vector3d::Zero();
  /// deg: the 95th percentile of the angle from the truth turned by the drive's known mount
  /// (TruthDrive::mount), and of that rotation's parts about the poses' body axes x, y and z.
  double turn_less_mount_p95 = 0.0;
  Eigen::Vector3d turn_axes_p95 = Eigen::Vector3d::Zero();
  std::size_t fixes = 0, rejected = 0, far = 0, far_rejected = 0;
};
TruthScore scoreAgainstTruth(const TruthDrive& d, const GeoreferenceResult& r);
/// One line of `s` for drive `name`: RMSE / MAX, the ends' MAX and the middle's, the fixes
/// rejected.
std::string describeScore(const std::string& name, const TruthScore& s);

/// A result's pose sigmas against the drive's truth (sim::sigmaCoverage).
sim::SigmaCoverage sigmaCoverage(const TruthDrive& d, const GeoreferenceResult& r);

/// The calibration of the defaults on one drive: its coverage, median sigma and RMSE (m).
struct CalibrationRow {
  std::string name;
  sim::SigmaCoverage coverage;
  double median_h = 0.0, rmse = 0.0;
};

/// The calibration table (markdown): a row per drive, then the RTK and the urban drives pooled.
void printCalibrationRows(const std::vector<CalibrationRow>& rows);

/// fusion: false, 3 cm for fixes without a std-dev (urban GNSS gives none): the simple way the
/// defaults are held against.
Params simpleWay();

/// The published method on these drives: GNSS control points at the poses' stamps as given,
/// no refinement, no fusion (0.03 m for fixes without a std-dev).
Params publishedMethod(int control_points = Params().control_points);

/// The defaults, `fusion: false` and the published method on each drive and GNSS kind in
/// `dirs` (the kinds a folder lacks are left out), one markdown row each; `sets` are applied
/// to every method.
void printTruthDriveRows(const std::vector<std::string>& dirs, int control_points,
                         const std::vector<std::pair<std::string, std::string>>& sets,
                         double shift);

}  // namespace flexcloud::study
