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
// The noise floors of outputs slower than the fit's sample rate, corrected. The floor is the
// residual's white part from lag-one differences; a role interpolated between frames P fit
// samples apart (P = its mean interval x fit_rate_hz > 1) carries noise that changes only at its
// frames, so its lag-one differences are about 1/P of white noise's and the floor reads P times
// low. Each such floor is multiplied by P, with a note in fit.identifiability.notes.
void ScaleFloorsForSlowRoles(const WindowSnapshot& snap, double fit_rate_hz, identify::IdentificationResult& fit);

// The model-choice refits as the checks read them.
adequacy::ModelChoiceFacts ModelChoiceFactsOf(const ModelChoice& choice, double eg_se_published_deg_per_g);

}  // namespace ndsid::pipeline
