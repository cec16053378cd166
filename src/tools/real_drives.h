#pragma once
// The leave-out study of real drives (doc/ACCURACY.md): a folder with slam_poses_tum.txt and
// gnss_local_at_poses.txt (../shared/data/a2rl and ../shared/data/monza have this shape), every
// n-th fix held out of the run, the result's trajectory compared with the held-out fixes at
// their own instants. No ground truth exists for such a drive: this is the measure.

#include <string>
#include <utility>
#include <vector>

#include "flexcloud/georeference.h"

namespace flexcloud::study {

/// The drive in a folder; throws Error naming the file when one is missing or unreadable.
DriveInput loadRealDrive(const std::string& dir);

/// The fixes of a drive split into those the run sees and those held out (every `every`-th,
/// starting at every / 2).
struct LeaveOutSplit {
  DriveInput run;
  std::vector<GnssPoint> held_out;
};
LeaveOutSplit holdOut(const DriveInput& drive, std::size_t every);

/// Where a drive's GNSS runs ahead of its SLAM, from the drive alone (no flexcloud clock code):
/// at each pose, the SLAM of the 21 poses around it fitted rigidly to their GNSS rows, the
/// fix's distance along the track from the fitted pose against how much faster than its
/// neighbours the car went there. A lag of dt puts a fix dt x (that change of speed) ahead.
struct LagSample {
  double speed = 0.0;         ///< m/s at the pose (GNSS)
  double speed_change = 0.0;  ///< m/s, less the mean of the window
  double along = 0.0;         ///< m, the fix ahead of the fitted pose along the track
};
std::vector<LagSample> lagSamples(const DriveInput& drive);

/// The least-squares slope of `along` on `speed_change` (s): the GNSS clock ahead of the
/// SLAM's. a2rl 0.097 s; monza 0.000 s (its rows share one made-up clock).
double lagOf(const std::vector<LagSample>& samples);

/// The held-out fixes' distances from a result's rubber-sheeted trajectory, each fix at
/// SLAM time stamp + `offset` (s): the drive's true instants, whatever clock the result chose.
ErrorStats heldOutError(const GeoreferenceResult& r, const Params& p,
                        const std::vector<GnssPoint>& held_out, double offset);

/// One line on how a result came about: the method used and the leave-out's scores, the clock
/// offset, the fixes rejected, the fusion's estimates and time.
std::string notesOf(const GeoreferenceResult& r);

/// The methods compared on every real drive: the published method, the simple way
/// (fusion: false) without and with the defaults' clock offset, and the defaults, each scored
/// at the drive's true instants (lagOf). Prints one markdown row each; `sets` are applied to
/// every method.
void printRealDriveRows(const std::string& dir, std::size_t every, int control_points,
                        const std::vector<std::pair<std::string, std::string>>& sets);

}  // namespace flexcloud::study
