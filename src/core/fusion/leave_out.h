#pragma once
// The choice between the fusion and the GNSS control points by leave-out (LeaveOutChoice).
// Private to the core.

#include <vector>

#include "flexcloud/georeference.h"

namespace flexcloud {

/// The fold of every prepared fix: stretches of params.leave_out_block seconds from the first
/// fix, dealt to the params.leave_out_folds folds in turn. No folds when the leave-out is off.
LeaveOutFolds leaveOutFolds(const std::vector<GnssPoint>& gnss, const Params& params);

/// Scores the fusion (its folds were solved with the fusion, r.fusion->leave_out_deviation) and
/// the GNSS control points (a run of the pipeline with fusion: false and the fusion's clock
/// offset, one per fold without the fold's fixes) at the held-out fixes, and makes `r` the GNSS
/// control points' result where they win. `r` holds the fusion's result.
void chooseByLeaveOut(const DriveInput& input, const Params& params, const LeaveOutFolds& folds,
                      const CancelToken& cancel, GeoreferenceResult& r);

}  // namespace flexcloud
