#pragma once
// Markers for rviz: pure functions from a result to MarkerArrays. Each array starts with a
// DELETEALL so a republished result replaces the previous one.

#include <visualization_msgs/MarkerArray.h>

#include "flexcloud/georeference.h"

namespace flexcloud::markers {

/// An array that only clears what an earlier one showed (a withdrawn result).
visualization_msgs::MarkerArray cleared(const std::string& frame);

/// Control points at their GNSS position: spheres coloured by how far the rigid alignment left
/// them (green 0 m to red >= 2 m), with that residual as text.
visualization_msgs::MarkerArray controlPoints(const GeoreferenceResult& r, const std::string& frame,
                                              const ros::Time& stamp);

/// The fixes the fusion rejected as outliers: red spheres at the fixes; empty without fusion.
visualization_msgs::MarkerArray rejectedFixes(const GeoreferenceResult& r, const std::string& frame,
                                              const ros::Time& stamp);

/// The tetrahedra edges in the ENU frame (after the rubber sheet).
visualization_msgs::MarkerArray tetrahedra(const GeoreferenceResult& r, const std::string& frame,
                                           const ros::Time& stamp);

/// The rubber-sheeted trajectory coloured by its deviation from the GNSS (green 0 m to red at
/// `red_at` metres; grey where the pose has no GNSS).
visualization_msgs::MarkerArray deviation(const GeoreferenceResult& r, const std::string& frame,
                                          const ros::Time& stamp, double red_at = 0.5);

/// The rubber-sheeted trajectory coloured by how far it may lie from the truth: its 1-sigma per
/// horizontal axis, green 0 m to red at `red_at` metres (max_sigma_h) and beyond.
visualization_msgs::MarkerArray sigma(const GeoreferenceResult& r, const std::string& frame,
                                      const ros::Time& stamp, double red_at);

}  // namespace flexcloud::markers
