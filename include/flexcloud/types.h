#pragma once
// Plain data types shared by every stage of the core. No ROS in here.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace flexcloud {

/// Error raised by the core for bad input or an impossible request; what() is one line that
/// names the input and the problem.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A geodetic GNSS fix: WGS84 latitude/longitude in degrees, ellipsoidal altitude in metres,
/// 1-sigma std-devs in metres along east, north and up. stamp in seconds.
struct GeoFix {
  double stamp = 0.0;
  double lat = 0.0;
  double lon = 0.0;
  double alt = 0.0;
  Eigen::Vector3d std_enu = Eigen::Vector3d::Zero();
};

/// A GNSS position in the local ENU frame of the datum (metres), with its 1-sigma std-devs (m).
struct GnssPoint {
  double stamp = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d std_dev = Eigen::Vector3d::Zero();
  /// The 3D std-dev, sqrt(se^2 + sn^2 + su^2), in metres.
  double stdDev3d() const { return std_dev.norm(); }
  /// The horizontal std-dev the std-dev threshold is compared with: the larger of the east and
  /// north ones (m); NaN where either is unknown.
  double stdDevH() const {
    return std_dev.head<2>().allFinite() ? std_dev.head<2>().maxCoeff()
                                         : std::numeric_limits<double>::quiet_NaN();
  }
};

/// A 6-DoF pose of the SLAM trajectory: position (m) and orientation of the body in its frame.
struct Pose {
  double stamp = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

using Trajectory = std::vector<Pose>;

/// Deviation statistics of a set of 3D distances, in metres.
struct ErrorStats {
  double mae = 0.0;   ///< mean of the distances
  double std = 0.0;   ///< standard deviation of the distances
  double max = 0.0;   ///< largest distance
  double rmse = 0.0;  ///< root of the mean squared distance
  std::size_t count = 0;
};

/// How the GNSS is sampled at a pose stamp: the cubic through four fixes, or the nearest fix.
enum class InterpolationMode { kSpline, kNearest };

/// A closed time interval [begin, end] in seconds.
struct TimeRange {
  double begin = 0.0;
  double end = 0.0;
  bool contains(double t) const { return t >= begin && t <= end; }
};

}  // namespace flexcloud
