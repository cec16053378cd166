#pragma once
// PCD clouds of a simulated map.

#include <pcl/PCLPointCloud2.h>

#include <utility>
#include <vector>

#include "flexcloud/sim/drive_simulator.h"

namespace flexcloud::sim {

/// The SLAM map as a SLAM system writes it: x y z (float32, map frame), intensity (float32),
/// ring (uint16), label (uint32); with `time`, also time (float64, s: the stamp of the scan that
/// saw the point, on the odometry's clock), as a LiDAR SLAM saves a map whose points know their
/// pose.
pcl::PCLPointCloud2 slamCloud(const SimMap& map, bool time = false);

/// The map as a keyframe SLAM saves it: per pose of the drive that saw points, that pose (SLAM
/// map frame) and its points in its own frame (the fields of slamCloud()), in the map's order.
std::vector<std::pair<Pose, pcl::PCLPointCloud2>> keyframeClouds(const SimDrive& d);

/// The map as a LiDAR SLAM publishes its registered scans: per pose of the drive that saw
/// points, that pose and its points in the SLAM's map frame (slamCloud()'s rows of that scan).
std::vector<std::pair<Pose, pcl::PCLPointCloud2>> registeredScans(const SimDrive& d);

/// The truth: the same points in the same order, x y z as float64 in the true ENU frame of the
/// simulator's datum, with the same other fields.
pcl::PCLPointCloud2 truthCloud(const SimMap& map);

}  // namespace flexcloud::sim
