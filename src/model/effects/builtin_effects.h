// Factories of the built-in effects. To add one: write its .cc beside these (see
// docs/adding-an-effect.md) and add one line to the table in builtin_effects.cc.
#pragma once

#include <memory>

#include "ndsid/config/config.h"
#include "ndsid/model/effect.h"

namespace ndsid::model {

std::shared_ptr<const Effect> MakeSteerOffset();
std::shared_ptr<const Effect> MakeSteerDelay();
std::shared_ptr<const Effect> MakeSpeedScale();
std::shared_ptr<const Effect> MakeSpeedOffset();
std::shared_ptr<const Effect> MakeSpeedDelay();
std::shared_ptr<const Effect> MakeCrossfall();
std::shared_ptr<const Effect> MakeRoadBank();
std::shared_ptr<const Effect> MakeSuperelevation();
std::shared_ptr<const Effect> MakeRelaxation();
std::shared_ptr<const Effect> MakeTyreSaturation();
std::shared_ptr<const Effect> MakeLoadChange();
std::shared_ptr<const Effect> MakeAccelBias();
std::shared_ptr<const Effect> MakeLeverArm();
std::shared_ptr<const Effect> MakeRoll();
std::shared_ptr<const Effect> MakeGyroOffset();
std::shared_ptr<const Effect> MakeGyroOffsetPerDrive();
std::shared_ptr<const Effect> MakeGyroScale();
std::shared_ptr<const Effect> MakeAccelScale();
std::shared_ptr<const Effect> MakeGyroDelay();
// The built-in effect of that name, nullptr if none.
std::shared_ptr<const Effect> MakeBuiltinEffect(const std::string& name);
// An effect stated as a formula (model.formulas); throws ConfigError (see EffectLibrary).
std::shared_ptr<const Effect> MakeFormulaEffect(const config::FormulaSpec& spec);

}  // namespace ndsid::model
