// The facts the checks of the fit judge (adequacy/fit_checks.h), gathered from a fit and the
// snapshot it was made on.
#pragma once

#include "ndsid/adequacy/fit_checks.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/pipeline/pipeline.h"

namespace ndsid::pipeline {

// choice: the model-choice refits (none or not judged: FitFacts::model_choice stays empty).
adequacy::FitFacts FitFactsOf(const identify::IdentificationResult& fit, const WindowSnapshot& snap,
                              const ModelChoice* choice = nullptr);
// The model-choice refits as the checks read them.
adequacy::ModelChoiceFacts ModelChoiceFactsOf(const ModelChoice& choice, double eg_se_published_deg_per_g);

}  // namespace ndsid::pipeline
