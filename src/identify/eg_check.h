// The EG check of an incremental solution (private to the identify stage, docs/incremental.md):
// a sample of the prior's chunks is simulated at the solution, the error of their predicted
// scores (J'e) is scaled to the whole prior, and the Newton step it implies moves EG by `shift`;
// beyond kEgCheck of EG's standard deviation the prior's quadratics do not hold there (every
// prior segment is then relinearised and the update solved again). The same sample checks EG's
// variance (kSigmaCheck).
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "fit_problem.h"
#include "incremental_prior.h"

namespace ndsid::identify {

// What the check found.
struct EgCheckResult {
  bool eg = true;     // the quadratics' error moves EG by at most kEgCheck sigma
  bool sigma = true;  // ... and its variance by at most kSigmaCheck
  double shift = 0;   // that move [sigma]
};

// The check of the prior's quadratics at theta (pm: the prior's moments there). An exact update
// (IncrementalUpdate::exact) holds them to the tighter limits kExactEgCheck and kExactSigmaCheck.
EgCheckResult CheckEg(const FitSettings& settings, const ParameterBox& box, const IncrementalPrior& prior,
                      const IncrementalPrior::Moments& pm, const std::vector<double>& theta,
                      const std::shared_ptr<const OutputWeights>& weights, bool exact);

// One sampled prior chunk, simulated at the solution. Along v = H^-1 g (H the prior's J'J, g
// EG's gradient): its true score v.(J'e) and |Jv|^2, against its quadratic's predictions
// v.(s_c + H_c d) and v'H_c v.
struct EgCheckSample {
  double vs = 0, vs_pred = 0, vhv = 0, vhv_pred = 0;
};

// The check's estimates from a sample of the prior's `total` chunks, scaled to all of them:
//   shift  |total/n sum(vs - vs_pred)| / sd       EG's move, in its standard deviations sd;
//   bread  |total/n sum(vhv - vhv_pred)| / g'H^-1g  the relative error of EG's variance's bread;
//   meat   |sum(vs^2 - vs_pred^2)| / sum(vs_pred^2) that of its cluster-robust meat (a ratio).
// Each with its standard error from the spread of the sampled chunks' terms, as for a simple
// random sample of the chunks (the sums scaled: total s / sqrt(n); the ratio's by the jackknife,
// infinite where leaving one chunk out leaves no predicted meat); 0 below two samples.
struct EgCheckEstimates {
  size_t sampled = 0;
  double shift = 0, shift_se = 0;
  double bread = 0, bread_se = 0;
  double meat = 0, meat_se = 0;
  // Every estimate within its limit with kEgCheckClearZ of its standard errors to spare (false
  // below two samples): a smaller sample already decides the check.
  bool clear(double eg_limit, double sigma_limit) const;
};
inline constexpr double kEgCheckClearZ = 2.0;
EgCheckEstimates EstimateEgCheck(const std::vector<EgCheckSample>& samples, size_t total, double sd, double g_hinv_g);

}  // namespace ndsid::identify
