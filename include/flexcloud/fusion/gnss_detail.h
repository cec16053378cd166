#pragma once
// The fused trajectory is the SLAM's shape under a slowly changing correction. Where the SLAM
// is wrong from pose to pose (a jitter, or a vertical error that changes from scan to scan),
// that shape is the wrong one, and the fusion measured by how much (each fix's slam_jitter).
// There, each pose between two inlier fixes moves toward them by the weight of the two
// estimates of its position: the fused one, uncertain by the SLAM's jitter, and the fixes',
// uncertain by their own std-dev, gain = jitter^2 / (jitter^2 + std_dev^2) per axis. Where the
// SLAM is smooth the jitter is 0 and nothing moves; outliers are never used.

#include <vector>

#include "flexcloud/fusion/fusion.h"

namespace flexcloud {

/// Moves the positions of `fused.poses` by the fixes' detail (see above) and fills its
/// slam_jitter_*, detail_gain, detail_poses and detail_max_shift.
void takeGnssDetail(FusionResult& fused);

}  // namespace flexcloud
