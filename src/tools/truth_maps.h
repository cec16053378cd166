#pragma once
// Maps as a LiDAR SLAM makes them, from a real drive with a truth (truth_drives.h): a scan every
// few poses, points at body-frame offsets like a car's LiDAR sees them (the ground below the
// sensor, walls and poles beside the road 2-50 m out, a few metres up), placed by the SLAM's
// poses (the map) and by the true poses at their true instants (its truth, point by point). A
// result's map is judged against that truth: horizontally and vertically, by distance from the
// point's pose, and away from the places where another pass comes near.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "flexcloud/georeference.h"
#include "truth_drives.h"

namespace flexcloud::study {

struct DriveMap {
  std::vector<Eigen::Vector3d> slam;   ///< map frame, as the SLAM placed each point
  std::vector<Eigen::Vector3d> truth;  ///< the GNSS's frame, as the true pose places it
  std::vector<std::size_t> pose;       ///< the pose each point was seen from
  std::vector<float> range;            ///< horizontal distance from that pose, m
  /// Whether a pose of another pass (more than 60 s apart) lies within 30 m of the point, by
  /// the truth or in the SLAM's map: where passes the SLAM holds apart meet.
  std::vector<bool> revisit;
};

/// The map of a drive: a scan at every `every`-th pose, `per_scan` points each; the same points
/// for the same seed. Points of poses without a truth are left out.
DriveMap makeDriveMap(const TruthDrive& d, std::size_t every = 5, std::size_t per_scan = 80,
                      std::uint64_t seed = 1);

/// A map 12.5 times as dense (a scan at every pose, 200 points each, another seed): where the
/// SLAM holds passes apart, a real map's cells hold points of each, which the sparse map's
/// cells mostly do not show.
DriveMap makeDenseDriveMap(const TruthDrive& d);

/// Distance bands from the point's pose (m): 0-10, 10-30, 30-50.
constexpr int kBands = 3;

/// A map's errors against its truth, horizontal and vertical (m): every point, by band, and
/// away from revisits; RMSE, 95th percentile and MAX each.
struct Spread {
  double rmse = 0.0, p95 = 0.0, max = 0.0;
  std::size_t points = 0;
};
struct MapScore {
  Spread h, v;  ///< every point
  Spread band_h[kBands], band_v[kBands];
  Spread away_h, away_v;  ///< away from revisits
};

/// How honest a map's point sigmas are: the share of its points within 2.45 sigma_h of the
/// truth horizontally (the 95 % circle), by band, and within 1.96 sigma_v vertically.
struct SigmaCover {
  double band_h[kBands] = {0.0, 0.0, 0.0};
  double v = 0.0;
};

/// The score of the map moved point by point by `place` (SLAM map point, point index -> ENU).
MapScore scoreMap(const DriveMap& m,
                  const std::function<Eigen::Vector3d(const Eigen::Vector3d&, std::size_t)>& place);

/// The rubber sheet of a result applied to the map.
MapScore scoreSheet(const DriveMap& m, const GeoreferenceResult& r);
/// The point sigmas of the sheet's map (point_sigma.h, the model of `p`) against its errors.
SigmaCover sheetSigmaCover(const DriveMap& m, const GeoreferenceResult& r, const Params& p);
/// Each point moved with its own pose's correction: the fused pose against the SLAM's (what the
/// map's poses allow).
MapScore scoreOwnPose(const DriveMap& m, const TruthDrive& d, const GeoreferenceResult& r);

/// Each point moved with the correction of the SLAM pose nearest to it (3D, in the SLAM's map).
/// Where the SLAM holds two passes apart, a point seen from one pass but nearer to the other
/// takes the other's correction.
MapScore scoreNearestPose(const DriveMap& m, const TruthDrive& d, const GeoreferenceResult& r);

/// The floor of a plain map (x, y, z alone): each point placed by the affine map fitted, by
/// least squares against the truth, to the points of its 5 m cell of the SLAM's map. A warp by
/// place knows no more of a point than where the SLAM put it; where the SLAM lays points of
/// passes that need different corrections in one cell, no warp affine within the cell serves
/// them all. Every figure is fitted to its own points (away from revisits: to those alone).
/// Judged on a dense map (makeDenseDriveMap()): a cell of 4 points or fewer is fitted exactly.
MapScore scoreFloor(const DriveMap& m);

/// The map saved as a LiDAR SLAM saves it with per-point time (x, y, z float32, time float64,
/// the scan's odometry stamp) and rebuilt from it (pose_rebuild.h), as the tool moves it.
MapScore scoreRebuilt(const DriveMap& m, const TruthDrive& d, const GeoreferenceResult& r);
/// The point sigmas of that rebuilt map (each point's own pose's) against its errors.
SigmaCover rebuiltSigmaCover(const DriveMap& m, const TruthDrive& d, const GeoreferenceResult& r,
                             const Params& p);

/// The table (markdown) of the sheet's and the own poses' map errors on each drive and GNSS
/// kind in `dirs`, with the defaults and `sets` applied.
void printTruthMapRows(const std::vector<std::string>& dirs, int control_points,
                       const std::vector<std::pair<std::string, std::string>>& sets);

}  // namespace flexcloud::study
