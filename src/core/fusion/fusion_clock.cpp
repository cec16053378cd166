// The fusion's clock offset: from the speed and heading profiles, refined by the fit of
// positions and restamped to the millisecond.
#include <algorithm>
#include <cmath>
#include <optional>

#include "fusion_graph.h"

namespace flexcloud {
namespace fusion_graph {

void Fusion::estimateClock() {
  std::vector<GnssPoint> taking_part;
  for (const auto& f : fixes_) taking_part.push_back(gnss_[f.input]);
  const ClockOffsetEstimate speed =
      estimateClockOffset(poses_, taking_part, options_.max_time_offset);
  ClockOffsetEstimate heading;
  if (options_.max_time_offset > 0.0) {
    heading = estimateHeadingOffset(poses_, options_.lever_arm, taking_part,
                                    speed.observable ? speed.offset : 0.0);
    if (std::abs(heading.offset) > options_.max_time_offset) heading.observable = false;
  }
  out_.clock = combineClock(speed, heading);
  // The fusion refines the offset only where the profiles tell it from 0, within their sigma.
  clock_ = speed;
  clock_.observable = out_.clock.observable;
  clock_.offset = out_.clock.offset;
  clock_.sigma = out_.clock.sigma;
  shift_ = clock_.observable ? clock_.offset : 0.0;
  dt_ = 0.0;
}

void Fusion::restamp() {
  for (int round = 0; round < kRestampRounds; ++round) {
    if (!clock_.observable || !(std::abs(dt_) > kRestampTolerance)) break;
    solveRestampedAt(shift_ + dt_);
  }
}

void Fusion::solveRestampedAt(double shift) {
  shift_ = shift;
  dt_ = 0.0;
  selectFixes();
  prepareFixes(unknown_h_, unknown_v_);
  const auto full = makeProblem(1);
  solveAt(*full, 0.0, 10);
}

void Fusion::holdClockWhereTheSpeedsDisagree() {
  out_.time_offset_from_positions = shift_ + dt_;
  const std::optional<double> held = heldClockOffset(shift_ + dt_, clock_);
  if (!held) return;
  out_.time_offset_held = true;
  solveRestampedAt(*held);
}

}  // namespace fusion_graph
}  // namespace flexcloud
