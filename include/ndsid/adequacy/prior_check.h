// How far a fit ended from its configured priors (model.priors, e.g. a fleet prior,
// docs/fleet.md): each prior parameter's z = (estimate - prior value) / prior sd, and the
// Mahalanobis distance over them (the priors are independent Gaussians: sqrt of the sum of the
// squared z). A distance whose square exceeds the chi-square 0.999 quantile of as many degrees of
// freedom says the data contradict the prior (a loaded van started from its model's prior): the
// estimate is a compromise between the two and the prior should be dropped for this vehicle.
#pragma once

#include <string>
#include <vector>

#include "ndsid/config/config.h"

namespace ndsid::adequacy {

struct FittedParameter {
  std::string name;
  double value = 0;
  bool fixed = false;
};

struct PriorDistance {
  std::vector<std::pair<std::string, double>> z;  // per free prior parameter
  double distance = 0;   // sqrt(sum z^2)
  double threshold = 0;  // sqrt of the chi-square 0.999 quantile for z.size() degrees of freedom
  bool contradicts = false;
  std::string Note() const;  // "posterior 2.1 prior sds from model.priors (cv -1.2, ...)" (+ ": contradicts them")
};

// The distance of `fit` from `priors` (free parameters with a prior only; none: z empty).
PriorDistance DistanceFromPriors(const std::vector<FittedParameter>& fit, const std::vector<config::ParameterPrior>& priors);

// The chi-square distribution's 0.999 quantile with `dof` degrees of freedom (a table for 1..10,
// Wilson-Hilferty beyond).
double Chi2Quantile999(size_t dof);

}  // namespace ndsid::adequacy
