// `ndsid compare`: a model beside a baseline on the same replayed window. Both are fitted on
// the training drives and simulated over every window sample; the residual is binned by
// operating condition against the noise floor ("where it fails"). Writes compare.csv,
// bins.csv, summary.json and an offline report.html with plots (docs/model-workflow.md).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "command_registry.h"
#include "html_report.h"
#include "ndsid/identify/result_codec.h"
#include "model_report.h"
#include "ndsid/model/effect_library.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/model/single_track.h"

namespace ndsid::desk {
namespace {
namespace fs = std::filesystem;

struct CompareArgs {
  std::string config = std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml";
  std::vector<std::string> logs;
  std::string effects;
  bool model_from_config = false;
  std::string baseline = "none";
  std::string out;
  std::string hold_out;
  double noise_floor = -1;
};

std::string Num(const char* fmt, double v) {
  char b[64];
  std::snprintf(b, sizeof b, fmt, v);
  return b;
}

nlohmann::json ModelJson(const FittedModel& m, const FitFigures& train, const FitFigures& val, double white,
                         double overall) {
  const auto& f = m.fit;
  nlohmann::json j = identify::ResultToJson(f);
  j["label"] = m.label;
  j["effects"] = m.effects;
  j["fit_rmse_train_mps2"] = f.rmse_train_mps2;
  j["fit_rmse_validation_mps2"] = f.rmse_validation_mps2;
  for (const auto& [name, ff] : {std::pair{"train", train}, std::pair{"validation", val}}) {
    j[name] = {{"rmse_mps2", ff.rmse}, {"nrmse_fit_pct", ff.nrmse_fit_pct}, {"bias_mps2", ff.bias}, {"samples", ff.n}};
  }
  j["white_noise_mps2"] = white;
  j["rmse_all_scored_mps2"] = overall;
  return j;
}

// bins.csv (a_y, m/s^2) and yaw_bins.csv (the yaw rate, deg/s): the where-it-fails tables; and
// gain_bands.csv, the signed view by speed of both outputs.
void WriteResidualTables(const fs::path& d, const Comparison& c) {
  const size_t nm = c.models.size();
  auto write_bins = [&](const std::vector<Bin>& bins, const std::string& unit, const char* file) {
    std::string csv = "group,label,model,n,clusters,bias_" + unit + ",se_" + unit + ",rmse_" + unit + ",verdict\n";
    for (const Bin& b : bins)
      for (size_t m = 0; m < nm; ++m) {
        const BinStats& s = b.per_model[m];
        char line[256];
        std::snprintf(line, sizeof line, "\"%s\",\"%s\",%s,%zu,%d,%.6g,%.6g,%.6g,%s\n", b.group.c_str(), b.label.c_str(),
                      c.models[m].label.c_str(), s.n, s.clusters, s.bias, std::isfinite(s.se) ? s.se : -1.0, s.rmse,
                      VerdictText(s.verdict));
        csv += line;
      }
    WriteFileAtomically((d / file).string(), csv);
  };
  write_bins(c.bins, "mps2", "bins.csv");
  if (c.has_yaw_rate) write_bins(c.yaw_bins, "degps", "yaw_bins.csv");
  WriteFileAtomically((d / "gain_bands.csv").string(),
                      GainViewCsv(c.gains, c.models, "a_y", true) +
                          (c.has_yaw_rate ? GainViewCsv(c.yaw_gains, c.models, "yaw_rate", false) : std::string()));
}

std::string WriteComparison(const std::string& dir, const ReplayedData& data, const Comparison& c) {
  fs::create_directories(dir);
  const fs::path d(dir);
  const size_t nm = c.models.size();
  {  // compare.csv: every window sample, every model
    std::string csv = "t_s,drive,segment,chunk,k,scored,set,steer_rad,steer_rate_radps,speed_mps,ax_mps2,ay_meas_mps2";
    for (const auto& m : c.models) csv += ",ay_" + m.label + "_mps2,resid_" + m.label + "_mps2";
    csv += ",yaw_rate_meas_radps";
    for (const auto& m : c.models) csv += ",yaw_rate_" + m.label + "_radps";
    csv += "\n";
    char line[160];
    for (const SampleRow& r : c.rows) {
      std::snprintf(line, sizeof line, "%.3f,%lld,%d,%d,%d,%d,%s,%.9g,%.6g,%.9g,%.9g,%.9g", r.t_s,
                    static_cast<long long>(r.drive), r.segment, r.chunk, r.k, r.scored ? 1 : 0,
                    r.validation ? "validation" : "train", r.steer_rad, r.steer_rate_radps, r.speed_mps, r.ax_mps2,
                    r.ay_mps2);
      csv += line;
      for (size_t m = 0; m < nm; ++m) {
        std::snprintf(line, sizeof line, ",%.9g,%.9g", r.ay_model[m], r.ay_mps2 - r.ay_model[m]);
        csv += line;
      }
      csv += std::isfinite(r.yaw_rate_radps) ? Num(",%.9g", r.yaw_rate_radps) : std::string(",");
      for (size_t m = 0; m < nm; ++m) csv += Num(",%.9g", r.yaw_model[m]);
      csv += "\n";
    }
    WriteFileAtomically((d / "compare.csv").string(), csv);
  }
  WriteResidualTables(d, c);
  nlohmann::json j;
  j["data"] = data.outcome.name;
  j["wheelbase_m"] = data.config.vehicle.wheelbase_m;
  j["noise_floor_mps2"] = c.noise_floor;
  j["noise_floor_source"] = c.noise_floor_source;
  if (data.truth_noise_mps2) j["truth_lat_accel_noise_mps2"] = *data.truth_noise_mps2;
  j["rule"] = {{"min_samples", kMinBinSamples}, {"bias_z", kBiasZ}, {"rmse_factor", kRmseFactor},
               {"gain_z", kGainZ}, {"gain_min", kGainMin}};
  j["gain_view"]["a_y"] = nlohmann::json::parse(GainViewJson(c.gains, c.models));
  if (c.has_yaw_rate) j["gain_view"]["yaw_rate"] = nlohmann::json::parse(GainViewJson(c.yaw_gains, c.models));
  for (size_t m = 0; m < nm; ++m) {
    j["models"].push_back(ModelJson(c.models[m], c.train[m], c.validation[m], c.white_noise[m], c.overall_rmse[m]));
  }
  if (c.has_yaw_rate) {
    nlohmann::json y;
    y["fitted"] = c.yaw_rate_fitted;
    y["noise_floor_degps"] = c.yaw_noise_floor;
    for (size_t m = 0; m < nm; ++m) {
      y["models"].push_back({{"label", c.models[m].label},
                             {"rmse_train_degps", c.yaw_train[m].rmse},
                             {"rmse_validation_degps", c.yaw_validation[m].n ? c.yaw_validation[m].rmse : -1.0},
                             {"bias_train_degps", c.yaw_train[m].bias},
                             {"white_noise_degps", c.yaw_white_noise[m]},
                             {"rmse_all_scored_degps", c.yaw_overall_rmse[m]}});
    }
    j["yaw_rate"] = y;
  }
  WriteFileAtomically((d / "summary.json").string(), j.dump(2) + "\n");

  std::string why_not;
  const bool plots = RunPlotScript("compare", dir, &why_not);
  std::string h = "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>ndsid compare</title>\n<style>"
                  "body{font-family:sans-serif;max-width:1200px;margin:auto}table{border-collapse:collapse;font-size:13px}"
                  "td,th{border:1px solid #bbb;padding:2px 6px;text-align:right}td.l,th.l{text-align:left}"
                  ".fail{background:#f6c0c0}.few{color:#999}img{max-width:100%}</style></head><body>\n";
  h += "<h1>ndsid compare: " + HtmlEscape(c.models[0].fit.model) + " vs " + HtmlEscape(c.models[1].fit.model) + "</h1>\n";
  h += "<p>Data: " + HtmlEscape(data.outcome.name) + ", " + std::to_string(data.window.training.size()) +
       " training and " + std::to_string(data.window.validation.size()) +
       " held-out segments. Residual e = a<sub>y,meas</sub> − a<sub>y,model</sub>; burn-in samples excluded.</p>\n";
  h += "<h2>Fit figures</h2>\n<table><tr><th class=l>model</th><th class=l>effects</th><th>EG [deg/g]</th><th>σ</th>"
       "<th>RMSE train</th><th>RMSE held-out</th><th>fit % train</th><th>fit % held-out</th><th>bias train</th>"
       "<th>bias held-out</th><th>white noise</th><th class=l>effect parameters</th></tr>\n";
  for (size_t m = 0; m < nm; ++m) {
    const auto& f = c.models[m].fit;
    std::string ep;
    for (const auto& p : f.effect_params) ep += p.name + " = " + Num("%.4g", p.value) + " ± " + Num("%.2g", p.se) + " " + p.unit + "; ";
    h += "<tr><td class=l>" + c.models[m].label + "</td><td class=l>" + HtmlEscape(JoinEffects(c.models[m].effects)) +
         "</td><td>" + Num("%.3f", f.eg_deg_per_g) + "</td><td>" + Num("%.3f", f.eg_se_deg_per_g) + "</td><td>" +
         Num("%.4f", c.train[m].rmse) + "</td><td>" + Num("%.4f", c.validation[m].rmse) + "</td><td>" +
         Num("%.1f", c.train[m].nrmse_fit_pct) + "</td><td>" + Num("%.1f", c.validation[m].nrmse_fit_pct) + "</td><td>" +
         Num("%+.4f", c.train[m].bias) + "</td><td>" + Num("%+.4f", c.validation[m].bias) + "</td><td>" +
         Num("%.4f", c.white_noise[m]) + "</td><td class=l>" + HtmlEscape(ep) + "</td></tr>\n";
  }
  h += "</table>\n<p>RMSE in m/s²; fit % = 100·(1 − |e|/|y − ȳ|). Noise floor " + Num("%.4f", c.noise_floor) +
       " m/s² (" + HtmlEscape(c.noise_floor_source) + ")" +
       (data.truth_noise_mps2 ? "; the simulator's truth file lists a_y sensor noise " + Num("%.3f", *data.truth_noise_mps2) + " m/s²" : std::string()) +
       ".</p>\n";
  h += "<h2>Where it fails</h2>\n<p>A bin fails on <b>bias</b> when |bias| &gt; " + Num("%g", kBiasZ) +
       "× its standard error clustered by chunk (at least 3 chunks) and |bias| &gt; half the noise floor; on <b>RMSE</b> "
       "when its RMSE &gt; " + Num("%g", kRmseFactor) + "× the model's overall RMSE; bins with fewer than " +
       std::to_string(kMinBinSamples) + " samples are not judged.</p>\n<table><tr><th class=l>group</th><th class=l>bin</th>";
  auto bins_table = [&](const std::vector<Bin>& bins, const char* fmt) {
    for (const auto& m : c.models) h += "<th>n</th><th>" + m.label + " bias</th><th>SE</th><th>RMSE</th><th>verdict</th>";
    h += "</tr>\n";
    for (const Bin& b : bins) {
      h += "<tr><td class=l>" + HtmlEscape(b.group) + "</td><td class=l>" + HtmlEscape(b.label) + "</td>";
      for (const BinStats& s : b.per_model) {
        const bool fail = s.verdict == BinVerdict::kFailBias || s.verdict == BinVerdict::kFailRmse;
        const std::string cls = fail ? " class=fail" : (s.verdict == BinVerdict::kTooFew ? " class=few" : "");
        h += "<td>" + std::to_string(s.n) + "</td><td" + cls + ">" + Num(fmt, s.bias) + "</td><td>" +
             Num("%.4f", std::isfinite(s.se) ? s.se : 0.0) + "</td><td" + cls + ">" + Num("%.4f", s.rmse) + "</td><td" +
             cls + ">" + VerdictText(s.verdict) + "</td>";
      }
      h += "</tr>\n";
    }
  };
  bins_table(c.bins, "%+.4f");
  h += "</table>\n" + GainViewHtml(c.gains, c.models, "a<sub>y</sub>") + "<table>";
  if (c.has_yaw_rate) {
    h += "</table>\n<h2>Where it fails: yaw rate</h2>\n<p>Residual e<sub>r</sub> = r<sub>meas</sub> − r<sub>model</sub> in deg/s "
         "(the modelled measured yaw rate, gyro effects included; " +
         std::string(c.yaw_rate_fitted ? "fitted as an output" : "not fitted: predicted by the a<sub>y</sub> fit") +
         "), the same bins and rule against its own noise floor " + Num("%.4f", c.yaw_noise_floor) + " deg/s. RMSE train / held-out: ";
    for (size_t m = 0; m < nm; ++m)
      h += c.models[m].label + " " + Num("%.4f", c.yaw_train[m].rmse) + " / " +
           (c.yaw_validation[m].n ? Num("%.4f", c.yaw_validation[m].rmse) : std::string("n/a")) + " deg/s" + (m + 1 < nm ? "; " : ".");
    h += "</p>\n<table><tr><th class=l>group</th><th class=l>bin</th>";
    bins_table(c.yaw_bins, "%+.4f");
    h += "</table>\n" + GainViewHtml(c.yaw_gains, c.models, "yaw-rate") + "<table>";
  }
  h += "</table>\n<h2>Plots</h2>\n";
  if (plots) {
    const std::pair<const char*, const char*> figs[] = {
        {"timeseries.png", "Measured vs modelled a<sub>y</sub> on a held-out stretch (the validation chunk with the largest a<sub>y</sub> spread; the study's Fig. 7)."},
        {"residual_bins.png", "Residual against a<sub>y</sub>, v, steering rate and a<sub>x</sub>: binned mean ± standard deviation; grey band: ± noise floor."},
        {"yaw_residual_bins.png", "Yaw-rate residual against a<sub>y</sub>, v, steering rate and a<sub>x</sub>: binned mean ± standard deviation; grey band: ± its noise floor."},
        {"steady_state.png", "Quasi-steady samples (|steering rate| &lt; 0.05 rad/s): δ<sub>sw</sub>/i<sub>s</sub> − l·r/v against a<sub>y</sub> with each model's EG line (the study's Fig. 8)."},
        {"coverage.png", "Coverage: g-g diagram and v–a<sub>y</sub> of the scored samples."}};
    for (const auto& [file, caption] : figs) {
      if (fs::exists(d / file)) h += "<figure><img src=\"" + std::string(file) + "\"><figcaption>" + caption + "</figcaption></figure>\n";
    }
  } else {
    h += "<p><b>No plots:</b> " + HtmlEscape(why_not) + ". The numbers above do not depend on them.</p>\n";
  }
  h += "<p>Files: <a href=\"compare.csv\">compare.csv</a>, <a href=\"bins.csv\">bins.csv</a>, "
       "<a href=\"gain_bands.csv\">gain_bands.csv</a>, " +
       std::string(c.has_yaw_rate ? "<a href=\"yaw_bins.csv\">yaw_bins.csv</a>, " : "") +
       "<a href=\"summary.json\">summary.json</a></p>\n</body></html>\n";
  WriteFileAtomically((d / "report.html").string(), h);
  if (!plots) std::printf("plots not written: %s\n", why_not.c_str());
  return (d / "report.html").string();
}

int Run(const CompareArgs& a) {
  // The configuration's effects (built-ins + its formulas): names are checked against them
  // before any work.
  const config::Config cfg = config::LoadConfig(a.config);
  const model::EffectLibrary library(cfg.model_formulas);
  std::vector<std::string> effects = a.effects.empty() ? cfg.model_effects : ParseEffectList(a.effects, library);
  const std::vector<std::string> baseline = ParseEffectList(a.baseline, library);
  const std::vector<int64_t> hold_out = ParseDriveList(a.hold_out);
  std::unique_ptr<ReplayedData> data = ReplayForModelWork(a.config, a.logs, effects);
  HoldOutDrives(*data, hold_out);
  std::vector<FittedModel> models;
  models.push_back(FitModel(*data, "model", effects));
  models.push_back(FitModel(*data, "baseline", baseline));
  const Comparison c = Compare(*data, std::move(models), a.noise_floor > 0 ? std::optional<double>(a.noise_floor) : std::nullopt);
  PrintComparison(c);
  const std::string out = a.out.empty() ? (fs::path(data->config.report_dir) / "compare").string() : a.out;
  const std::string html = WriteComparison(out, *data, c);
  std::printf("\nreport: %s\n", html.c_str());
  {  // the one-page report of what compare knows (html_report.h)
    HtmlReportInputs page;
    page.compare_dir = out;
    page.truth_yaml = TruthBeside(a.logs.empty() ? data->config.source.logs : a.logs);
    page.title = "ndsid compare: " + data->outcome.name;
    WriteCommandPage(out, page);
  }
  return 0;
}

void Register(CLI::App& parent, int& exit_code) {
  auto args = std::make_shared<CompareArgs>();
  auto* cmd = parent.add_subcommand("compare", "Fit a model and a baseline on replayed logs; where the model fails, with plots");
  cmd->add_option("--config", args->config, "Vehicle configuration (YAML)")->capture_default_str();
  cmd->add_option("--log", args->logs, "Log files (default: source.logs of the configuration)");
  auto* eff = cmd->add_option("--effects", args->effects, "Effects of the model, comma-separated; 'none' = base single-track");
  cmd->add_flag("--model-from-config", args->model_from_config, "The model is model.effects of the configuration (default)")->excludes(eff);
  cmd->add_option("--baseline", args->baseline, "Effects of the baseline model ('none' = base single-track)")->capture_default_str();
  cmd->add_option("--noise-floor", args->noise_floor, "Noise floor [m/s^2] for the verdicts (default: estimated from the residual)");
  cmd->add_option("--hold-out", args->hold_out,
                  "Drives to hold out, comma-separated drive numbers (default 'auto': the pipeline's split)");
  cmd->add_option("--out", args->out, "Output folder (default: <report_dir>/compare)");
  cmd->callback([args, &exit_code] { exit_code = Run(*args); });
}

}  // namespace
}  // namespace ndsid::desk

NDSID_REGISTER_COMMAND(compare, ndsid::desk::Register);
