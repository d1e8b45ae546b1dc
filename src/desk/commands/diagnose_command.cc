// `ndsid diagnose`: which physical effect is missing, and the error ladder. Replays the logs,
// fits the starting model, aligns the roles in time (step 0), ranks every candidate effect by a
// score test (discover::Diagnose), then adds effects one at a time while the held-out RMSE falls
// (discover::ClimbErrorLadder). --apply writes the ladder's effect list (model: effects: [...])
// and the applied latencies (signals.<role>.latency_s) into the configuration.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "command_registry.h"
#include "config_edit.h"
#include "html_report.h"
#include "model_report.h"
#include "outside_library.h"
#include "ndsid/model/effect_library.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/discover/diagnosis.h"
#include "ndsid/model/model_spec.h"

namespace ndsid::desk {
namespace {
namespace fs = std::filesystem;


struct DiagnoseArgs {
  std::string config = std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml";
  std::vector<std::string> logs;
  std::string effects;
  std::string candidates;
  int max_steps = 3;
  double z_threshold = discover::DiagnosisOptions{}.z_threshold;
  double unexplained_ratio = discover::LadderOptions{}.unexplained_ratio;
  bool apply = false;
  bool no_align = false;
  std::string out;
  std::string hold_out;
};

// What tells an effect apart from those it is confounded with (physics.md §4).
std::string Separation(const std::string& effect) {
  static const std::map<std::string, std::string> kHints = {
      {"accel_bias", "constant, also at standstill (compare the standstill a_y, net of the road's cross-slope); with road_bank in the model a steering offset also leaves a constant (the bank observer keeps the yaw rate straight), so only transients and standstill data separate the two"},
      {"crossfall", "even in a_y, ~ l/(l+EG v^2); yaw rate measures the road (v r - a_y) and standstill a_y shows the cross-slope"},
      {"road_bank", "needs yaw rate: the bank is tracked so that the model's yaw rate follows the measured one; sensor effects on a_y (bias, roll, lever arm) stay in the residual"},
      {"steer_offset", "even in a_y, grows with v^2/(l+EG v^2) on straights: the speed dependence separates it from bias (constant) and crossfall (~ l/L); with road_bank in the model it leaves a constant like a bias (standstill a_y separates them)"},
      {"roll", "odd in a_y and lagging: the steady part trades with is and EG; yaw rate (kinematic l r/v) or the ~1.5 Hz roll mode separate it; roll and bank act alike on the accelerometer"},
      {"superelevation", "odd in a_y: absorbed into is/EG from (d_sw, v, a_y) alone; yaw rate separates it"},
      {"speed_scale", "in the Ackermann term, trades with l/is; only weakly identifiable"},
      {"speed_offset", "in the Ackermann term like speed_scale but falling with speed (c/v); with the yaw rate, -c r in a_y - v r_meas separates it"},
      {"lever_arm", "~ yaw acceleration, zero in steady state: transients separate it"},
      {"speed_delay", "~ a_x times the speed's share of a_y and r: weak; step 0 estimates the speed's latency with the model (physics.md §5.0)"},
      {"steer_delay", "~ steering rate at all speeds (a constant time shift): align the signals first (physics.md §5.0)"},
      {"relaxation", "~ steering rate at low speed (lag sigma/v): the speed dependence separates it from a time skew"},
      {"tyre_saturation", "only data with |a_y| > 3 m/s^2 separate it from EG"},
      {"load_change", "per drive: within one drive a load is EG (and cv/m, ch/m) itself; only the drives' differences show it"},
      {"gyro_offset_per_drive", "per drive: a constant yaw-rate residual that differs between drives; each drive's standstills measure its own offset"},
  };
  const auto it = kHints.find(effect);
  return it != kHints.end() ? it->second : "";
}

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

std::string Fmt(const char* fmt, double a, double b = 0, double c = 0) {
  char buf[128];
  std::snprintf(buf, sizeof buf, fmt, a, b, c);
  return buf;
}

// A held-out RMSE, or "—" when no drive was held out (the fit's value is then negative).
std::string HeldOut(double rmse) { return rmse >= 0 ? Fmt("%.4f", rmse) : std::string("—"); }

// The added effect's parameters of a rung as "name = v ± se unit".
std::string AddedParams(const discover::Rung& r, const model::EffectLibrary& library) {
  if (!r.removed.empty()) return "(" + r.removed + " taken out again)";
  if (r.added.empty()) return "";
  const model::ModelSpec spec = model::ModelSpec::FromNames({r.added}, library);
  if (!spec.per_drive_params().empty()) {  // per-drive values: one per drive, the reference's the vector's
    std::string s;
    for (const auto& v : r.fit.drive_values) {
      s += (s.empty() ? v.param + ": drive " : "; drive ") + std::to_string(v.drive_id) +
           Fmt(" %.4g", v.value) + (v.reference ? " (reference)" : Fmt(" ± %.2g", v.se)) + (v.validation ? " (held out)" : "");
    }
    return s;
  }
  std::string s;
  for (int i = model::kNumParams; i < spec.num_params(); ++i) {
    for (const auto& p : r.fit.effect_params) {
      if (p.name == spec.param_name(i)) s += (s.empty() ? "" : "; ") + p.name + " = " + Fmt("%.4g ± %.2g ", p.value, p.se) + p.unit;
    }
  }
  return s;
}

// The report as it is written: the Markdown page and the JSON, filled section by section in the
// order the terminal shows them.
struct DiagnoseReport {
  std::string md;    // diagnosis.md
  nlohmann::json j;  // diagnosis.json
};

// Step 0: the roles' latencies relative to a_y (already-configured latencies are in the data).
// Returns the latencies --apply writes: each applied one added to the configured one.
std::map<config::Role, double> ReportAlignment(const discover::Ladder& ladder, const config::Config& config, DiagnoseReport& r) {
  std::map<config::Role, double> new_latency;
  if (ladder.alignment.empty()) return new_latency;
  std::printf("\nstep 0, time alignment (latency relative to a_y; shifts applied when significant):\n");
  r.md += "## Step 0: time alignment\n\nEach role's latency relative to the lateral acceleration, estimated by a "
          "time-shift search; significant ones are applied before the ladder.\n\n| role | latency [ms] | σ [ms] | "
          "applied | method | note |\n|---|---|---|---|---|---|\n";
  for (const auto& l : ladder.alignment) {
    const std::string key = config::RoleKey(l.role);
    const double configured = config.role(l.role) ? config.role(l.role)->latency_s : 0.0;
    if (l.apply) new_latency[l.role] = configured + l.latency_s;
    const std::string value = l.se_s > 0 || l.latency_s != 0 ? Fmt("%+8.1f ± %-6.1f ms", 1e3 * l.latency_s, 1e3 * l.se_s)
                                                                : std::string("       —          ");
    std::printf("  %-22s %s  %-7s %s%s\n", key.c_str(), value.c_str(), l.apply ? "applied" : "-", l.method.c_str(),
                l.note.empty() ? "" : (" (" + l.note + ")").c_str());
    r.md += "| " + key + " | " + Fmt("%+.1f", 1e3 * l.latency_s) + " | " + (l.determined ? Fmt("%.1f", 1e3 * l.se_s) : "—") +
            " | " + (l.apply ? "yes" : "no") + " | " + l.method + " | " + l.note + " |\n";
    r.j["alignment"].push_back({{"role", key}, {"latency_s", l.latency_s}, {"se_s", l.se_s}, {"determined", l.determined},
                                {"applied", l.apply}, {"configured_latency_s", configured}, {"method", l.method},
                                {"note", l.note}});
  }
  if (!ladder.look_alike.empty()) {
    std::printf("  %s added first (rung 1), it explains more of the held-out error than the shifts: %s; the latencies above "
                "are estimated again with it\n", ladder.look_alike.c_str(), ladder.look_alike_why.c_str());
    r.md += "\n" + ladder.look_alike + " added first (rung 1), it explains more of the held-out error than the shifts: " +
            ladder.look_alike_why + ". The latencies above are estimated again with it in the model.\n";
    r.j["look_alike"] = {{"effect", ladder.look_alike}, {"why", ladder.look_alike_why}};
  }
  if (ladder.aligned) {
    const auto& b = ladder.before_alignment;
    const auto& f = ladder.rungs.at(static_cast<size_t>(ladder.aligned_rung)).fit;
    std::printf("  aligned: RMSE train %.4f -> %.4f, held-out %s -> %s, EG %.3f -> %.3f deg/g\n", b.rmse_train_mps2,
                f.rmse_train_mps2, HeldOut(b.rmse_validation_mps2).c_str(), HeldOut(f.rmse_validation_mps2).c_str(),
                b.eg_deg_per_g, f.eg_deg_per_g);
    r.md += "\nAligned: RMSE train " + Fmt("%.4f → %.4f", b.rmse_train_mps2, f.rmse_train_mps2) + ", held-out " +
            HeldOut(b.rmse_validation_mps2) + " → " + HeldOut(f.rmse_validation_mps2) + ", EG " +
            Fmt("%.3f → %.3f deg/g", b.eg_deg_per_g, f.eg_deg_per_g) + ". The ladder below works on the aligned data.\n\n";
  } else if (!ladder.alignment_rejected.empty()) {
    std::printf("  not applied: %s; the ladder works on the data as recorded\n", ladder.alignment_rejected.c_str());
    r.md += "\nNo latency applied (" + ladder.alignment_rejected + "): the ladder works on the data as recorded.\n\n";
    r.j["alignment_rejected"] = ladder.alignment_rejected;
  } else {
    r.md += "\nNo latency applied: the ladder works on the data as recorded.\n\n";
  }
  return new_latency;
}

// The first diagnosis: the candidates' ranking, the signatures, unexplained structure.
void ReportRanking(const discover::Diagnosis& d, DiagnoseReport& r) {
  std::printf("\nfirst diagnosis of %s: RMSE %.4f m/s^2 over %zu residuals\n", d.model.c_str(), d.rmse, d.residuals);
  std::printf("%-4s %-16s %-20s %14s %-6s %10s %8s %7s %8s %-4s %s\n", "rank", "effect", "parameter", "one-step", "unit",
              "pred.RMSE", "dRSS %", "unique", "z_rob", "sig", "confounded with");
  r.md += "## Candidate ranking (first diagnosis of " + d.model + ", RMSE " + Fmt("%.4f", d.rmse) +
          " m/s²)\n\n| rank | effect | parameter | one-step | unit | predicted RMSE | ΔRSS share | uniqueness | robust z | significant | confounded with |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  const double rss = d.rss;  // the scored RSS: the shares below are of it (at most 100 %)
  int rank = 0;
  for (const auto& c : d.ranked) {
    ++rank;
    const double share = rss > 0 ? 100.0 * c.drss / rss : 0.0;
    const std::string conf = c.confounded_with.empty() ? "" : Join(c.confounded_with) + " — separated by: " + Separation(c.effect);
    std::printf("%-4d %-16s %-20s %14.5g %-6s %10.4f %8.2f %7.3f %8.1f %-4s %s\n", rank, c.effect.c_str(), c.param.c_str(),
                c.one_step, c.unit.c_str(), c.rmse_predicted, share, c.uniqueness, c.z_robust, c.significant ? "yes" : "no",
                conf.c_str());
    r.md += "| " + std::to_string(rank) + " | " + c.effect + " | " + c.param + " | " + Fmt("%.5g", c.one_step) + " | " +
            c.unit + " | " + Fmt("%.4f", c.rmse_predicted) + " | " + Fmt("%.2f %%", share) + " | " +
            Fmt("%.3f", c.uniqueness) + " | " + Fmt("%.1f", c.z_robust) + " | " + (c.significant ? "yes" : "no") + " | " +
            conf + " |\n";
    r.j["ranking"].push_back({{"effect", c.effect}, {"param", c.param}, {"unit", c.unit}, {"one_step", c.one_step},
                              {"rmse_predicted_mps2", c.rmse_predicted}, {"drss_share", share / 100.0},
                              {"uniqueness", c.uniqueness}, {"z_robust", c.z_robust}, {"significant", c.significant},
                              {"confounded_with", c.confounded_with},
                              {"separated_by", c.confounded_with.empty() ? "" : Separation(c.effect)}});
  }
  const bool kin = !d.kinematic_signatures.empty();
  std::printf("\nresidual correlations with the signatures%s:\n", kin ? " (a_y's residual; beside it a_y - v r, measured)" : "");
  r.md += kin ? "\n## Residual correlations with the signatures\n\n| signal | r | robust z | ΔRSS share | a_y − v·r: r | a_y − v·r: z |\n|---|---|---|---|---|---|\n"
              : "\n## Residual correlations with the signatures\n\n| signal | r | robust z | ΔRSS share |\n|---|---|---|---|\n";
  for (const auto& s : d.signatures) {
    const double share = rss > 0 ? 100.0 * s.drss / rss : 0.0;
    const auto y = std::find_if(d.kinematic_signatures.begin(), d.kinematic_signatures.end(), [&](const auto& q) { return q.key == s.key; });
    const bool has_yaw = y != d.kinematic_signatures.end();
    std::printf("  %-48s r = %+.3f  z = %+6.1f  dRSS %5.2f %%%s\n", s.signal.c_str(), s.correlation, s.z_robust, share,
                has_yaw ? Fmt("   a_y - v r: r = %+.3f  z = %+6.1f  slope/a_y's %+.2f", y->correlation, y->z_robust, s.slope != 0 ? y->slope / s.slope : 0.0).c_str() : "");
    r.md += "| " + s.signal + " | " + Fmt("%+.3f", s.correlation) + " | " + Fmt("%+.1f", s.z_robust) + " | " + Fmt("%.2f %%", share) +
            (has_yaw ? " | " + Fmt("%+.3f", y->correlation) + " | " + Fmt("%+.1f", y->z_robust) : std::string()) + " |\n";
    nlohmann::json j = {{"key", s.key}, {"signal", s.signal}, {"correlation", s.correlation}, {"z_robust", s.z_robust}, {"drss_share", share / 100.0}};
    if (s.slope != 0) {
      j["slope"] = s.slope;
      j["slope_se"] = s.slope_se;
    }
    if (has_yaw) {
      if (y->slope != 0) {
        j["kinematic_slope"] = y->slope;
        j["kinematic_slope_se"] = y->slope_se;
      }
      j["kinematic_correlation"] = y->correlation;
      j["kinematic_z_robust"] = y->z_robust;
    }
    r.j["signatures"].push_back(j);
  }
  r.j["unexplained"] = d.unexplained;
  r.j["unexplained_text"] = d.unexplained_text;
  if (d.unexplained) {
    std::printf("unexplained: %s\n", d.unexplained_text.c_str());
    r.md += "\n**Unexplained:** " + d.unexplained_text + "\n";
  }
}

// The rungs, then every candidate the ladder refitted, kept or not, and why.
void ReportLadder(const discover::Ladder& ladder, const model::EffectLibrary& library, DiagnoseReport& r) {
  std::printf("\nerror ladder (stop: %s)\n%-4s %-42s %10s %10s %18s %-40s %8s\n", ladder.stop_reason.c_str(), "rung", "model",
              "RMSE train", "held-out", "EG ± σ [deg/g]", "added parameter ± σ", "ΔBIC");
  r.md += "\n## Error ladder\n\nStop: " + ladder.stop_reason + "\n\n| rung | model | RMSE train | RMSE held-out | EG ± σ [deg/g] | added parameter ± σ | ΔBIC |\n|---|---|---|---|---|---|---|\n";
  for (size_t i = 0; i < ladder.rungs.size(); ++i) {
    const auto& rung = ladder.rungs[i];
    const std::string added = AddedParams(rung, library);
    std::printf("%-4zu %-42s %10.4f %10s %9.3f ± %-6.3f %-40s %8.1f\n", i, rung.model.c_str(), rung.fit.rmse_train_mps2,
                HeldOut(rung.fit.rmse_validation_mps2).c_str(), rung.fit.eg_deg_per_g, rung.fit.eg_se_deg_per_g, added.c_str(),
                rung.delta_bic);
    r.md += "| " + std::to_string(i) + " | " + rung.model + " | " + Fmt("%.4f", rung.fit.rmse_train_mps2) + " | " +
            HeldOut(rung.fit.rmse_validation_mps2) + " | " + Fmt("%.3f ± %.3f", rung.fit.eg_deg_per_g, rung.fit.eg_se_deg_per_g) +
            " | " + added + " | " + (i ? Fmt("%.1f", rung.delta_bic) : std::string("")) + " |\n";
    r.j["ladder"].push_back({{"model", rung.model}, {"added", rung.added}, {"removed", rung.removed}, {"valid", rung.fit.valid},
                             {"rmse_train_mps2", rung.fit.rmse_train_mps2}, {"rmse_validation_mps2", rung.fit.rmse_validation_mps2},
                             {"eg_deg_per_g", rung.fit.eg_deg_per_g}, {"eg_se_deg_per_g", rung.fit.eg_se_deg_per_g},
                             {"added_parameters", added}, {"delta_bic", rung.delta_bic}});
  }
  if (ladder.trials.empty()) return;
  std::printf("\ncandidates refitted by the ladder:\n");
  r.md += "\n### Candidates refitted\n\n| rung | effect | held-out RMSE before → after | verdict |\n|---|---|---|---|\n";
  r.j["trials"] = nlohmann::json::array();
  for (const auto& t : ladder.trials) {
    const std::string where = t.step < 0 ? "step 0" : "rung " + std::to_string(t.step);  // step 0: its contest
    const char sign = t.removal ? '-' : '+';
    std::printf("  %-7s %c %-16s %.4f -> %.4f  %s\n", where.c_str(), sign, t.effect.c_str(), t.held_out_before, t.held_out_after,
                t.why.c_str());
    r.md += "| " + where + " | " + (t.removal ? "− " : "") + t.effect + " | " + Fmt("%.4f", t.held_out_before) + " → " +
            Fmt("%.4f", t.held_out_after) + " | " + t.why + " |\n";
    r.j["trials"].push_back({{"step", t.step}, {"effect", t.effect}, {"accepted", t.accepted},
                             {"held_out_before_mps2", t.held_out_before}, {"held_out_after_mps2", t.held_out_after},
                             {"yaw_before_radps", t.yaw_before}, {"yaw_after_radps", t.yaw_after},
                             {"delta_bic", t.delta_bic}, {"eg_shift_rel", t.eg_shift_rel},
                             {"eg_shift_sigma", t.eg_shift_sigma}, {"why", t.why}, {"removal", t.removal}});
  }
}

// After the ladder: each output's held-out residual against its noise floor, and whether EG is settled.
void ReportVerdicts(const discover::Ladder& ladder, DiagnoseReport& r) {
  if (!ladder.verdicts.empty()) {
    std::printf("\nafter the ladder (held-out residual against its noise floor, the white part):\n");
    r.md += "\n## After the ladder\n\n";
    r.j["verdicts"] = nlohmann::json::array();
    for (const auto& v : ladder.verdicts) {
      std::printf("  %s\n", v.text.c_str());
      r.md += std::string("- ") + (v.unexplained ? "**" : "") + v.text + (v.unexplained ? "**" : "") + "\n";
      r.j["verdicts"].push_back({{"output", v.output}, {"unit", v.unit}, {"rmse", v.rmse}, {"noise_floor", v.floor},
                                 {"ratio", v.ratio}, {"spread", v.spread}, {"residuals", v.residuals}, {"unexplained", v.unexplained}, {"text", v.text}});
    }
  }
  r.j["eg_unsettled"] = ladder.eg_unsettled;
  if (!ladder.eg_unsettled.empty()) {
    std::printf("  %s\n", ladder.eg_unsettled.c_str());
    r.md += "- **" + ladder.eg_unsettled + "**\n";
  }
}

// An unexplained output's signature and a formula that would state it (outside_library.h).
void ReportOutsideLibrary(const std::vector<OutsideLibrary>& found, DiagnoseReport& r) {
  r.j["outside_library"] = nlohmann::json::array();
  for (const OutsideLibrary& o : found) {
    std::printf("  %s\n", o.text.c_str());
    if (!o.formula_template.empty()) std::printf("\n%s\n", o.formula_template.c_str());
    r.md += "- " + o.text + (o.formula_template.empty() ? "\n" : "\n\n```yaml\n" + o.formula_template + "```\n");
    r.j["outside_library"].push_back({{"output", o.output}, {"signature", o.signature}, {"text", o.text},
                                      {"formula_template", o.formula_template}});
  }
}

// diagnosis.json, the ladder's plot, diagnosis.md and the one-page HTML report into `out`.
void WriteReport(DiagnoseReport& r, const std::string& out, const std::vector<std::string>& final_effects,
                 const std::vector<std::string>& logs, const std::string& title) {
  fs::create_directories(out);
  WriteFileAtomically((fs::path(out) / "diagnosis.json").string(), r.j.dump(2) + "\n");
  std::string why_not;
  if (RunPlotScript("ladder", out, &why_not)) {
    r.md += "\n![error ladder](error_ladder.png)\n";
  } else {
    r.md += "\nNo plot: " + why_not + "\n";
    std::printf("plot not written: %s\n", why_not.c_str());
  }
  r.md += "\nFinal effects: " + JoinEffects(final_effects) + "\n";
  WriteFileAtomically((fs::path(out) / "diagnosis.md").string(), r.md);
  std::printf("\nfinal effects: %s\nreport: %s\n", JoinEffects(final_effects).c_str(), (fs::path(out) / "diagnosis.md").c_str());
  HtmlReportInputs page;  // the one-page report of what diagnose knows (html_report.h)
  page.diagnose_dir = out;
  page.truth_yaml = TruthBeside(logs);
  page.title = title;
  WriteCommandPage(out, page);
}

// --apply: the ladder's effect list, the effects that leave EG unsettled (model.alternatives:
// written where there are some or the configuration lists some) and step 0's applied latencies
// written into the configuration.
void ApplyToConfig(const std::string& config_path, const std::vector<std::string>& final_effects,
                   const std::vector<std::string>& alternatives, const std::map<config::Role, double>& new_latency) {
  const std::string text = ReadWholeFile(config_path);
  std::string what, what_alternatives, what_latency;
  std::string edited = SetModelEffects(text, final_effects, config_path, &what);
  if (!alternatives.empty() || !config::ParseConfig(text, config_path).model_alternatives.empty()) {
    edited = SetModelList(edited, "alternatives", alternatives, config_path, &what_alternatives);
    what += "; " + what_alternatives;
  }
  if (!new_latency.empty()) edited = SetRoleLatencies(edited, new_latency, config_path, &what_latency);
  if (edited == text) {
    std::printf("--apply: %s unchanged, model.effects is already %s\n", config_path.c_str(), JoinEffects(final_effects).c_str());
  } else {
    WriteFileAtomically(config_path, edited);
    std::printf("--apply: %s: %s%s\n", config_path.c_str(), what.c_str(), what_latency.empty() ? "" : ("; " + what_latency).c_str());
  }
}

// --candidates: "a,b" replaces the library's default candidates, "+a,+b" adds to them. Each
// name is checked on its own: alternatives (effects sharing a parameter, which one model cannot
// hold together) may both be listed.
struct CandidateList {
  std::vector<std::string> names;
  bool extend = false;
};
CandidateList ParseCandidates(const std::string& text, const model::EffectLibrary& library) {
  CandidateList out;
  size_t plus = 0;
  for (std::string item : SplitNames(text)) {
    if (item[0] == '+') {
      ++plus;
      item.erase(0, 1);
    }
    if (item.empty()) continue;
    model::ModelSpec::FromNames({item}, library);  // throws ConfigError naming an unknown effect
    out.names.push_back(item);
  }
  if (plus != 0 && plus != out.names.size()) {
    throw ConfigError("--candidates: either every name has a '+' (added to the library's candidates) or none (the list replaces them)");
  }
  out.extend = plus != 0;
  return out;
}

// The ladder's options from the command line and the replayed data.
discover::LadderOptions MakeLadderOptions(const DiagnoseArgs& a, const CandidateList& candidates, const ReplayedData& data,
                                          const std::vector<std::string>& start) {
  discover::LadderOptions opt;
  opt.max_steps = a.max_steps;
  opt.diagnosis.candidates = candidates.names;
  opt.diagnosis.candidates_extend_library = candidates.extend;
  opt.diagnosis.z_threshold = a.z_threshold;
  opt.unexplained_ratio = a.unexplained_ratio;
  opt.negligible_spread_ratio = data.config.plausibility.rmse_negligible_spread_ratio;
  const double rate_hz = data.config.identification.rate_hz;
  opt.a_y_floor_factor = identify::SlowOutputFloorFactor(data.window.a_y_interval_s, rate_hz);
  opt.yaw_floor_factor = identify::SlowOutputFloorFactor(data.window.yaw_rate_interval_s, rate_hz);
  opt.align = !a.no_align;
  opt.standstill = data.window.standstill;
  opt.speed_scale_evidence = stats::EstimateSpeedScale(data.window.training);
  opt.steady_state = data.window.steady_state;
  opt.start_fit = ReplayedFit(data, start);  // the replay's own fit of the starting model
  return opt;
}

int Run(const DiagnoseArgs& a) {
  // The configuration's effects (built-ins + its formulas): names are checked against them
  // before any work.
  const config::Config cfg = config::LoadConfig(a.config);
  const model::EffectLibrary library(cfg.model_formulas);
  const std::vector<std::string> start = a.effects.empty() ? cfg.model_effects : ParseEffectList(a.effects, library);
  const CandidateList candidates = ParseCandidates(a.candidates, library);
  if (a.max_steps < 1) throw ConfigError("--max-steps must be >= 1");
  if (!(a.z_threshold > 0)) throw ConfigError("--z-threshold must be > 0");
  if (!(a.unexplained_ratio > 1)) throw ConfigError("--unexplained-ratio must be > 1 (a held-out RMSE / noise floor ratio)");
  const std::vector<int64_t> hold_out = ParseDriveList(a.hold_out);
  std::unique_ptr<ReplayedData> data = ReplayForModelWork(a.config, a.logs, start);
  HoldOutDrives(*data, hold_out);
  const discover::LadderOptions opt = MakeLadderOptions(a, candidates, *data, start);
  spdlog::info("{}", opt.speed_scale_evidence.note);
  const discover::Ladder ladder = discover::ClimbErrorLadder(data->config.identification, data->config.vehicle.wheelbase_m,
                                                             start, data->pipeline->library(), data->window.training,
                                                             data->window.validation, opt);
  const std::vector<std::string>& final_effects = ladder.final_effects;

  DiagnoseReport report;
  report.md = "# ndsid diagnose: " + data->outcome.name + "\n\nStart: " + JoinEffects(start) + "\n\n";
  report.j["data"] = data->outcome.name;
  report.j["start_effects"] = start;
  report.j["final_effects"] = final_effects;
  report.j["stop_reason"] = ladder.stop_reason;
  {
    const stats::SpeedScaleEvidence& e = opt.speed_scale_evidence;
    report.j["speed_scale_evidence"] = {{"available", e.available}, {"scale", e.scale}, {"se", e.se}, {"chunks", e.chunks},
                                        {"samples", e.samples}, {"note", e.note}};
  }
  std::printf("diagnose %s: start %s, %zu training / %zu held-out segments\n", data->outcome.name.c_str(),
              JoinEffects(start).c_str(), data->window.training.size(), data->window.validation.size());
  const std::map<config::Role, double> new_latency = ReportAlignment(ladder, data->config, report);
  // The speed signal's scale against a_x: evidence the lateral outputs cannot give.
  std::printf("\n%s\n", opt.speed_scale_evidence.note.c_str());
  report.md += "Speed scale: " + opt.speed_scale_evidence.note +
               (opt.speed_scale_evidence.available ? " (a prior on speed_scale in every fit below; docs/two-outputs.md)" : "") + ".\n\n";
  if (!ladder.diagnoses.empty()) ReportRanking(ladder.diagnoses.front(), report);
  ReportLadder(ladder, library, report);
  ReportVerdicts(ladder, report);
  ReportOutsideLibrary(JudgeOutsideLibrary(*data, ladder, final_effects), report);
  const std::string out = a.out.empty() ? (fs::path(data->config.report_dir) / "diagnose").string() : a.out;
  WriteReport(report, out, final_effects, a.logs.empty() ? data->config.source.logs : a.logs,
              "ndsid diagnose: " + data->outcome.name);
  if (a.apply) ApplyToConfig(a.config, final_effects, ladder.eg_unsettled_effects, new_latency);
  return 0;
}

void Register(CLI::App& parent, int& exit_code) {
  auto args = std::make_shared<DiagnoseArgs>();
  auto* cmd = parent.add_subcommand("diagnose", "Rank the missing physical effects and climb the error ladder on replayed logs");
  cmd->add_option("--config", args->config, "Vehicle configuration (YAML)")->capture_default_str();
  cmd->add_option("--log", args->logs, "Log files (default: source.logs of the configuration)");
  cmd->add_option("--effects", args->effects, "Starting effects, comma-separated (default: model.effects; 'none' = base)");
  cmd->add_option("--candidates", args->candidates, "Candidate effects, comma-separated: replace the library's default candidates, or with a '+' on every name (+my_formula) add to them (default: every library effect)");
  cmd->add_option("--max-steps", args->max_steps, "Most effects the ladder's climb adds (a look-alike or the speed scale from a_x before it and the standstill rung after it come on top)")->capture_default_str();
  cmd->add_option("--z-threshold", args->z_threshold,
                  "Significance filter: |robust score z| a candidate needs before the ladder refits with it")
      ->capture_default_str();
  cmd->add_option("--unexplained-ratio", args->unexplained_ratio,
                  "After the ladder: an output whose held-out RMSE exceeds this times its noise floor is reported unexplained")
      ->capture_default_str();
  cmd->add_flag("--apply", args->apply,
                "Write the ladder's final effect list, and the significant latencies of step 0, into the configuration file");
  cmd->add_flag("--no-align", args->no_align, "Skip step 0 (time alignment of the roles relative to a_y)");
  cmd->add_option("--hold-out", args->hold_out,
                  "Drives to hold out, comma-separated drive numbers (default 'auto': the pipeline's split)");
  cmd->add_option("--out", args->out, "Output folder (default: <report_dir>/diagnose)");
  cmd->callback([args, &exit_code] { exit_code = Run(*args); });
}

}  // namespace
}  // namespace ndsid::desk

NDSID_REGISTER_COMMAND(diagnose, ndsid::desk::Register);
