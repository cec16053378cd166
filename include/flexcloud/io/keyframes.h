#pragma once
// A LiDAR SLAM's keyframe dump, as hdl_graph_slam and interactive_slam (and the SLAM systems that
// write their format) save it: a folder with one subfolder per keyframe, each holding `data`
// (`stamp SEC NSEC`, then `estimate` and its 4x4 pose in the SLAM's map frame, row by row) and
// `cloud.pcd` (the keyframe's points in its own frame). The keyframes' poses are the drive's
// SLAM trajectory, and the map is rebuilt from them: each keyframe's points moved with its own
// pose's correction.

#include <string>
#include <vector>

#include "flexcloud/io/outputs.h"
#include "flexcloud/types.h"
#include "flexcloud/warp/pose_rebuild.h"

namespace flexcloud {

class PointSigmaField;

/// MapInfo::pose_field of a map rebuilt from a keyframe dump.
constexpr const char* kKeyframeDump = "keyframe dump";

struct Keyframe {
  std::string cloud;  ///< its cloud.pcd
  Pose pose;          ///< stamp and pose in the SLAM's map frame
};

/// Parses a keyframe's `data` text (`name` in errors): its stamp and its `estimate`, a rigid
/// transform to within 1e-4 (its rotation re-orthonormalised). Throws Error naming `name` and
/// the line for a missing stamp or estimate, a line that is not numbers, or a matrix that is not
/// a rigid transform.
Pose parseKeyframeData(const std::string& text, const std::string& name);

/// A keyframe's `data` text for `pose`: its stamp, estimate and odom (the same matrix, full
/// precision) and accum_distance -1, as the dump's readers expect.
std::string keyframeDataText(const Pose& pose);

/// The keyframes of a dump folder (every subfolder with `data` and `cloud.pcd`), by stamp.
/// Throws Error naming the folder or file: none found, unreadable, two of the same stamp, or
/// clouds whose fields differ from the first one's.
std::vector<Keyframe> readKeyframes(const std::string& dir);

/// The keyframes' poses as the SLAM trajectory.
Trajectory keyframePoses(const std::vector<Keyframe>& keyframes);

/// Writes every keyframe's cloud into one binary PCD at `out` (under a temporary name, renamed
/// when complete), a keyframe at a time: each point placed by its keyframe's pose and moved with
/// `corrections` at its stamp (rebuildKeyframe()), every field kept, with `sigmas` set sigma_h
/// and sigma_v after them; fills info (counts, a sample of the map, seconds). Throws Error for
/// a bad cloud or a write failure, or once `cancel` is cancelled.
void writeKeyframeMap(const std::vector<Keyframe>& keyframes, const PoseCorrections& corrections,
                      const std::string& out, const PointSigmaField* sigmas,
                      const CancelToken& cancel, MapInfo& info);

}  // namespace flexcloud
