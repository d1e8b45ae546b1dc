// The facts the checks of the fit judge (adequacy/fit_checks.h), gathered from a fit and the
// snapshot it was made on.
#pragma once

#include "ndsid/adequacy/fit_checks.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/pipeline/pipeline.h"

namespace ndsid::pipeline {

adequacy::FitFacts FitFactsOf(const identify::IdentificationResult& fit, const WindowSnapshot& snap);

}  // namespace ndsid::pipeline
