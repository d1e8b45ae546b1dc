// After the error ladder, an output left unexplained: what its error behaves like, read from the
// signed view of the final model (compare's gain per speed band), and a formula that would state
// it (docs/adding-an-effect.md). The library's effects have been tried by then; this names the
// kind of physics that is missing, not an effect.
#pragma once

#include <string>
#include <vector>

#include "model_report.h"
#include "ndsid/discover/diagnosis.h"

namespace ndsid::desk {

struct OutsideLibrary {
  std::string output;            // "a_y" or "yaw rate"
  std::string signature;         // "gain changes with speed", "gain at every speed", "not a gain"
  std::string text;              // the verdict in words, with the bands' gains
  std::string formula_template;  // YAML for model.formulas ("" when no template fits)
};

// One entry per output the ladder left unexplained (ladder.verdicts), judged on the final model
// `final_effects` with the final rung's fit, over the window of `data`: a shape in the steering
// (an offset odd or even in it) when the final model's residual signatures name one ahead of
// every gain, else the signed view's gain per speed band.
std::vector<OutsideLibrary> JudgeOutsideLibrary(const ReplayedData& data, const discover::Ladder& ladder,
                                                const std::vector<std::string>& final_effects);

}  // namespace ndsid::desk
