#include "fit_json.h"

namespace ndsid::desk {

nlohmann::json FitToJson(const identify::IdentificationResult& f) {
  nlohmann::json j;
  j["model"] = f.model;
  j["valid"] = f.valid;
  j["reason"] = f.reason;
  j["eg_rad_per_mps2"] = f.eg_rad_per_mps2;
  j["eg_se_rad_per_mps2"] = f.eg_se_rad_per_mps2;
  j["eg_deg_per_g"] = f.eg_deg_per_g;
  j["eg_se_deg_per_g"] = f.eg_se_deg_per_g;
  j["se_method"] = f.se_method;
  j["parameters"] = nlohmann::json::array();
  auto add = [&](const identify::ParameterEstimate& p) {
    j["parameters"].push_back({{"name", p.name}, {"value", p.value}, {"se", p.se}, {"unit", p.unit},
                               {"fixed", p.fixed}, {"at_bound", p.at_bound}});
  };
  for (const auto& p : f.params) add(p);
  for (const auto& p : f.effect_params) add(p);
  j["values"] = f.AllValues();
  j["drive_loads"] = nlohmann::json::array();  // load_change: per-drive m, Jz ratio to the reference drive
  for (const auto& l : f.drive_loads) {
    j["drive_loads"].push_back({{"drive", l.drive_id}, {"ratio", l.ratio}, {"se", l.se}, {"reference", l.reference},
                                {"held_out", l.validation}});
  }
  j["correlation"] = f.correlation;
  j["rmse_train_mps2"] = f.rmse_train_mps2;
  j["rmse_validation_mps2"] = f.rmse_validation_mps2;
  j["residuals_train"] = f.residuals_train;
  j["residuals_validation"] = f.residuals_validation;
  j["iterations"] = f.iterations;
  j["solve_seconds"] = f.solve_seconds;
  j["identifiability"]["condition_number"] = f.identifiability.condition_number;
  j["identifiability"]["weak"] = nlohmann::json::array();
  for (const auto& w : f.identifiability.weak) j["identifiability"]["weak"].push_back(w.description);
  j["identifiability"]["notes"] = f.identifiability.notes;
  return j;
}

}  // namespace ndsid::desk
