// The verdicts after the ladder has stopped: whether EG is settled (Ladder::eg_unsettled), and
// each output's held-out residual against its noise floor (JudgeOutputs, diagnosis.h).
#pragma once

#include <string>
#include <vector>

#include "ndsid/discover/diagnosis.h"

namespace ndsid::discover {

// A refit of the final rung that was not added, moves EG by more than
// LadderOptions::eg_relevant_shift_rel and eg_unsettled_sigma of its standard error, and raises no
// fitted output's held-out RMSE by more than eg_unsettled_rmse_ratio.
bool LeavesEgUnsettled(const Trial& t, int final_step, const LadderOptions& options);

// The trials of the ladder's final rung that leave EG unsettled (LeavesEgUnsettled), in order.
std::vector<const Trial*> TrialsLeavingEgUnsettled(const Ladder& ladder, const LadderOptions& options);

// Ladder::eg_unsettled: "" when no refit of the final rung leaves EG unsettled, else which do and
// by how much. (When the step limit ended the ladder, nothing was refitted on the final model.)
std::string DescribeUnsettledEg(const Ladder& ladder, const LadderOptions& options);

// The shift step 0 applied to the measured yaw rate, in samples of `judged` (0: none).
double YawShiftSamples(const std::vector<RoleLatency>& alignment, const identify::SegmentList& judged);

}  // namespace ndsid::discover
