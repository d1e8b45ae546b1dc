#include "ndsid/identify/result_codec.h"

#include <string>

namespace ndsid::identify {

namespace {

constexpr size_t kMaxEffectParams = 256;
constexpr size_t kMaxListed = 1'000'000;

nlohmann::json HalfJson(const HalfEstimate& h) {
  return {{"valid", h.valid}, {"reason", h.reason}, {"eg_rad_per_mps2", h.eg_rad_per_mps2},
          {"eg_se_rad_per_mps2", h.eg_se_rad_per_mps2}, {"drives", h.drives}, {"chunks", h.chunks},
          {"in_time", h.in_time}};
}

HalfEstimate HalfFromJson(const JsonIn& in) {
  HalfEstimate h;
  h.valid = in.Bool("valid");
  h.reason = in.String("reason");
  h.eg_rad_per_mps2 = in.Number("eg_rad_per_mps2");
  h.eg_se_rad_per_mps2 = in.Number("eg_se_rad_per_mps2");
  h.drives = static_cast<int>(in.Int64("drives"));
  h.chunks = in.UInt64("chunks");
  if (in.Has("in_time")) h.in_time = in.Bool("in_time");
  return h;
}

nlohmann::json ParamJson(const ParameterEstimate& p) {
  return {{"name", p.name},         {"value", p.value},       {"se", p.se},
          {"unit", p.unit},         {"fixed", p.fixed},       {"at_bound", p.at_bound},
          {"eg_correlation", p.eg_correlation}, {"eg_release_shift_rad_per_mps2", p.eg_release_shift_rad_per_mps2}};
}

ParameterEstimate ParamFromJson(const JsonIn& in) {
  ParameterEstimate p;
  p.name = in.String("name");
  p.unit = in.String("unit");
  p.value = in.Number("value");
  p.se = in.Number("se");
  p.fixed = in.Bool("fixed");
  p.at_bound = in.Bool("at_bound");
  if (in.Has("eg_correlation")) p.eg_correlation = in.Number("eg_correlation");  // older states lack these
  if (in.Has("eg_release_shift_rad_per_mps2")) p.eg_release_shift_rad_per_mps2 = in.Number("eg_release_shift_rad_per_mps2");
  return p;
}

}  // namespace

nlohmann::json ResultToJson(const IdentificationResult& f) {
  nlohmann::json j;
  j["model"] = f.model;
  j["valid"] = f.valid;
  j["reason"] = f.reason;
  j["eg_rad_per_mps2"] = f.eg_rad_per_mps2;
  j["eg_se_rad_per_mps2"] = f.eg_se_rad_per_mps2;
  j["eg_deg_per_g"] = f.eg_deg_per_g;
  j["eg_se_deg_per_g"] = f.eg_se_deg_per_g;
  j["se_method"] = f.se_method;
  j["eg_se_fit_rad_per_mps2"] = f.eg_se_fit_rad_per_mps2;  // before the halves widened it
  j["eg_bound_shift_rad_per_mps2"] = f.eg_bound_shift_rad_per_mps2;
  if (f.eg_prior_info_share > 0) j["eg_prior_info_share"] = f.eg_prior_info_share;  // with priors only
  if (f.halves) j["halves"] = {HalfJson(f.halves->first), HalfJson(f.halves->second)};
  j["floor_a_y_mps2"] = f.floor_a_y_mps2;
  j["floor_yaw_radps"] = f.floor_yaw_radps;
  j["parameters"] = nlohmann::json::array();
  for (int i = 0; i < model::kNumParams; ++i) {  // the base parameters under their fixed names
    ParameterEstimate p = f.params[i];
    p.name = model::kParamNames[i];
    p.unit = model::kParamUnits[i];
    j["parameters"].push_back(ParamJson(p));
  }
  for (const auto& p : f.effect_params) j["parameters"].push_back(ParamJson(p));
  j["values"] = f.AllValues();  // the parameters' values alone, base then effects (ModelSpec layout)
  j["drive_values"] = nlohmann::json::array();  // per-drive parameters (e.g. load_change's load_ratio)
  for (const auto& v : f.drive_values) {
    j["drive_values"].push_back({{"drive", v.drive_id}, {"param", v.param}, {"value", v.value}, {"se", v.se},
                                 {"reference", v.reference}, {"held_out", v.validation}});
  }
  j["correlation"] = f.correlation;
  j["rmse_train_mps2"] = f.rmse_train_mps2;
  j["rmse_validation_mps2"] = f.rmse_validation_mps2;
  j["residuals_train"] = f.residuals_train;
  j["residuals_validation"] = f.residuals_validation;
  j["yaw_rate_output"] = f.yaw_rate_output;
  j["rmse_train_yaw_radps"] = f.rmse_train_yaw_radps;
  j["rmse_validation_yaw_radps"] = f.rmse_validation_yaw_radps;
  j["residuals_train_yaw"] = f.residuals_train_yaw;
  j["noise_level_a_y"] = f.noise_level_a_y;
  j["noise_level_yaw_rate"] = f.noise_level_yaw_rate;
  j["chunks"] = f.chunks;
  j["train_hours"] = f.train_hours;
  j["iterations"] = f.iterations;
  j["solve_seconds"] = f.solve_seconds;
  j["termination"] = f.termination;
  j["update"] = f.update;
  j["chunks_simulated"] = f.chunks_simulated;
  j["chunks_from_prior"] = f.chunks_from_prior;
  j["chunks_relinearized"] = f.chunks_relinearized;
  nlohmann::json& id = j["identifiability"];
  id["condition_number"] = f.identifiability.condition_number;
  id["singular_values"] = f.identifiability.singular_values;
  id["weak"] = nlohmann::json::array();
  id["weak_singular_value_ratios"] = nlohmann::json::array();
  for (const auto& w : f.identifiability.weak) {
    id["weak"].push_back(w.description);
    id["weak_singular_value_ratios"].push_back(w.singular_value_ratio);
  }
  id["notes"] = f.identifiability.notes;
  return j;
}

IdentificationResult ResultFromJson(const JsonIn& in) {
  IdentificationResult f;
  f.model = in.String("model");
  f.valid = in.Bool("valid");
  f.reason = in.String("reason");
  f.eg_rad_per_mps2 = in.Number("eg_rad_per_mps2");
  f.eg_se_rad_per_mps2 = in.Number("eg_se_rad_per_mps2");
  f.eg_deg_per_g = in.Number("eg_deg_per_g");
  f.eg_se_deg_per_g = in.Number("eg_se_deg_per_g");
  f.se_method = in.String("se_method");
  // The checks' facts (absent in states written before them).
  if (in.Has("eg_se_fit_rad_per_mps2")) f.eg_se_fit_rad_per_mps2 = in.Number("eg_se_fit_rad_per_mps2");
  if (in.Has("eg_bound_shift_rad_per_mps2")) f.eg_bound_shift_rad_per_mps2 = in.Number("eg_bound_shift_rad_per_mps2");
  if (in.Has("eg_prior_info_share")) {
    f.eg_prior_info_share = in.Number("eg_prior_info_share");
    if (!(f.eg_prior_info_share >= 0 && f.eg_prior_info_share <= 1)) in.At("eg_prior_info_share").Fail("not in [0, 1]");
  }
  if (in.Has("halves")) {
    const JsonIn h = in.At("halves");
    if (h.Size(2) != 2) h.Fail("not two halves");
    f.halves = std::make_pair(HalfFromJson(h.At(size_t{0})), HalfFromJson(h.At(size_t{1})));
  }
  if (in.Has("floor_a_y_mps2")) f.floor_a_y_mps2 = in.Number("floor_a_y_mps2");
  if (in.Has("floor_yaw_radps")) f.floor_yaw_radps = in.Number("floor_yaw_radps");
  const JsonIn ps = in.At("parameters");
  const size_t n = ps.Size(model::kNumParams + kMaxEffectParams);
  if (n < static_cast<size_t>(model::kNumParams)) ps.Fail("fewer than the " + std::to_string(model::kNumParams) + " base parameters");
  for (size_t i = 0; i < n; ++i) {
    ParameterEstimate p = ParamFromJson(ps.At(i));
    if (i < static_cast<size_t>(model::kNumParams)) {
      if (p.name != model::kParamNames[i]) ps.At(i).Fail("base parameter '" + p.name + "', expected '" + model::kParamNames[i] + "'");
      f.params[i] = std::move(p);
    } else {
      f.effect_params.push_back(std::move(p));
    }
  }
  if (in.Has("drive_values")) {
    const JsonIn values = in.At("drive_values");
    for (size_t i = 0, nv = values.Size(kMaxListed); i < nv; ++i) {
      const JsonIn v = values.At(i);
      f.drive_values.push_back(DriveValue{v.Int64("drive"), v.String("param"), v.Number("value"), v.Number("se"),
                                          v.Bool("reference"), v.Bool("held_out")});
    }
  } else {  // before per-drive parameters were generic: load_change's ratios as "drive_loads"
    const JsonIn loads = in.At("drive_loads");
    for (size_t i = 0, nl = loads.Size(kMaxListed); i < nl; ++i) {
      const JsonIn l = loads.At(i);
      f.drive_values.push_back(DriveValue{l.Int64("drive"), "load_ratio", l.Number("ratio"), l.Number("se"),
                                          l.Bool("reference"), l.Bool("held_out")});
    }
  }
  f.correlation = in.At("correlation").Numbers(n * n);
  if (!f.correlation.empty() && f.correlation.size() != n * n) in.At("correlation").Fail("not " + std::to_string(n) + " x " + std::to_string(n));
  f.rmse_train_mps2 = in.Number("rmse_train_mps2");
  f.rmse_validation_mps2 = in.Number("rmse_validation_mps2");
  f.residuals_train = in.UInt64("residuals_train");
  f.residuals_validation = in.UInt64("residuals_validation");
  f.yaw_rate_output = in.Bool("yaw_rate_output");
  f.rmse_train_yaw_radps = in.Number("rmse_train_yaw_radps");
  f.rmse_validation_yaw_radps = in.Number("rmse_validation_yaw_radps");
  f.residuals_train_yaw = in.UInt64("residuals_train_yaw");
  f.noise_level_a_y = in.Number("noise_level_a_y");
  f.noise_level_yaw_rate = in.Number("noise_level_yaw_rate");
  f.chunks = in.UInt64("chunks");
  f.train_hours = in.Number("train_hours");
  const int64_t iterations = in.Int64("iterations");
  if (iterations < 0 || iterations > 1'000'000'000) in.At("iterations").Fail("out of range");
  f.iterations = static_cast<int>(iterations);
  f.solve_seconds = in.Number("solve_seconds");
  f.termination = in.String("termination");
  if (in.Has("update")) {  // since the incremental update (older documents: a full-window fit)
    f.update = in.String("update");
    f.chunks_simulated = in.UInt64("chunks_simulated");
    f.chunks_from_prior = in.UInt64("chunks_from_prior");
    f.chunks_relinearized = in.UInt64("chunks_relinearized");
  }
  const JsonIn id = in.At("identifiability");
  f.identifiability.condition_number = id.Number("condition_number");
  const std::vector<double> sv = id.At("singular_values").Numbers(model::kNumParams);
  for (size_t i = 0; i < sv.size(); ++i) f.identifiability.singular_values[i] = sv[i];
  const std::vector<std::string> weak = id.At("weak").Strings(kMaxEffectParams + model::kNumParams);
  const std::vector<double> ratios = id.At("weak_singular_value_ratios").Numbers(weak.size());
  if (ratios.size() != weak.size()) id.At("weak_singular_value_ratios").Fail("not one per weak direction");
  for (size_t i = 0; i < weak.size(); ++i) f.identifiability.weak.push_back(WeakDirection{ratios[i], weak[i]});
  f.identifiability.notes = id.At("notes").Strings(1024);
  return f;
}

}  // namespace ndsid::identify
