// The held-out RMSE of a fit (private to the identify stage): each output's RMSE over the
// held-out segments at the estimate, from their chunks' quadratics (the incremental path) or by
// simulating them.
#pragma once

#include <vector>

#include "fit_problem.h"
#include "incremental_prior.h"
#include "ndsid/identify/linearized_window.h"

namespace ndsid::identify {

// From the held-out chunks' quadratics (LinearizedWindow::held_out: unweighted, both outputs'
// parts): those of the prior where the estimate theta lies within the distance rule `sigma_rule`
// of all their segment's points (as for the training segments), the others' simulated once with
// their Jacobian at the estimate, which gives their exact sums there and their quadratics for the
// next update (held_lin, one per held-out segment). An update thus simulates only new or stale
// held-out data. False, with nothing set, where a held-out chunk cannot be evaluated.
bool HeldOutFromQuadratics(const FitSettings& settings, const ParameterBox& box, const SegmentList& validation,
                           const std::vector<double>& theta, const IncrementalPrior* prior, double sigma_rule,
                           bool two_outputs, std::vector<LinearizedSegment>& held_lin, IdentificationResult& r);

// Both outputs' held-out RMSE from one simulation of each held-out chunk at the result's values.
void HeldOutBySimulation(const FitSettings& settings, const SegmentList& validation, bool two_outputs, IdentificationResult& r);

}  // namespace ndsid::identify
