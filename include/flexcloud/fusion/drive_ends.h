#pragma once
// At a drive's ends nothing lies beyond the fixes to tell them wrong: in the middle a run of
// rejected fixes has the SLAM's shape and the fixes on both sides against it, at an end only the
// SLAM's shape. A LiDAR odometry errs most in its first seconds (MulRan: at the launch from a
// standstill it moves about a second before the car does, 1.8-2.6 m ahead of it after the first
// 5 m), and the keyframe graph then rejects the fixes of the standstill, which agree with each
// other and with the truth (KAIST_02 with urban GNSS: 2.57 m off at the start, 2.12 m at most
// in the middle).
//
// Where the first (or last) fixes that took part are a run of code-grade fixes the graph
// rejected (at least kEndFixes; fixes as precise as the refinement takes, by their own std-dev
// or the measured noise of fixes without one, are its: precise_follow.h) whose errors from the
// result agree with each other within their noise,
// the poses up to the run's last fix move by the run's mean error, eased to none at the first
// fix the result follows; the run's fixes are used.

#include "flexcloud/fusion/fusion.h"

namespace flexcloud {

/// The two ends of `f` as above; what was followed goes to f.drive_ends_followed.
void followTheDrivesEnds(FusionResult& f);

}  // namespace flexcloud
