#include "replay_summary.h"

#include <cmath>
#include <cstdarg>
#include <cstdio>

#include "ndsid/model/single_track.h"
#include "ndsid/common/format.h"

namespace ndsid::desk {
namespace {

// The names of the failed checks, ", "-joined.
std::string FailedNames(const adequacy::PlausibilityReport& pl) {
  std::string out;
  for (const adequacy::Check& c : pl.checks)
    if (c.verdict == adequacy::Verdict::kFailed) out += (out.empty() ? "" : ", ") + c.name;
  return out;
}

bool HasEg(const identify::IdentificationResult& f) { return std::isfinite(f.eg_deg_per_g) && f.eg_se_deg_per_g > 0; }

void PrintEstimate(const pipeline::Estimate& e, const ReplayOutcome& outcome) {
  const identify::IdentificationResult& f = e.fit;
  std::printf("  EG = %.4f ± %.4f deg/g   (%.6f ± %.6f rad/(m/s^2), 1 sigma)%s\n", f.eg_deg_per_g, f.eg_se_deg_per_g,
              f.eg_rad_per_mps2, f.eg_se_rad_per_mps2, f.valid ? "" : ("   NOT VALID: " + FailedNames(e.plausibility)).c_str());
  if (!f.valid && FailedNames(e.plausibility).empty()) std::printf("  not valid: %s\n", f.reason.c_str());
  if (outcome.truth_eg) {
    std::printf("  truth EG = %.4f deg/g (simulator); error %+.2f %% = %+.1f sigma\n", model::EgToDegPerG(*outcome.truth_eg),
                100 * (f.eg_rad_per_mps2 - *outcome.truth_eg) / *outcome.truth_eg,
                (f.eg_rad_per_mps2 - *outcome.truth_eg) / f.eg_se_rad_per_mps2);
  }
  auto mark = [&](int i) { return f.params[i].at_bound ? " (on its bound)" : ""; };
  std::printf("  is = %.3f%s, lv = %.3f m%s, cv = %.0f N/rad%s, ch = %.0f N/rad%s, Jz = %.0f kg m^2%s, m = %.0f kg (%s)\n",
              f.params[model::kSteerRatio].value, mark(model::kSteerRatio), f.params[model::kCgToFront].value,
              mark(model::kCgToFront), f.params[model::kStiffFront].value, mark(model::kStiffFront),
              f.params[model::kStiffRear].value, mark(model::kStiffRear), f.params[model::kYawInertia].value,
              mark(model::kYawInertia), f.params[model::kMass].value, f.params[model::kMass].fixed ? "fixed" : "identified");
  char validation[48] = "n/a (no held-out drive)";  // rounded, never cut
  if (f.rmse_validation_mps2 >= 0) std::snprintf(validation, sizeof validation, "%.4f m/s^2", f.rmse_validation_mps2);
  std::printf("  RMSE train %.4f m/s^2, validation %s\n", f.rmse_train_mps2, validation);
  if (f.yaw_rate_output) {
    std::printf("  yaw rate (fitted too): RMSE train %.4f deg/s, validation %s\n", f.rmse_train_yaw_radps * 180 / M_PI,
                YawValidationText(f.rmse_validation_yaw_radps, "n/a (no held-out drive)").c_str());
  }
  for (const auto& p : f.effect_params)
    std::printf("  %s = %.5g ± %.2g %s%s\n", p.name.c_str(), p.value, p.se, p.unit.c_str(),
                p.fixed ? " (fixed)" : (p.at_bound ? " (on its bound)" : ""));
}

void PrintChecks(const adequacy::PlausibilityReport& pl) {
  std::printf("  checks:");
  const char* sep = " ";
  for (const auto& c : pl.checks) {
    if (c.verdict == adequacy::Verdict::kSkipped) {
      std::printf("%s%s skipped", sep, c.name.c_str());
    } else {
      std::printf("%s%s %s (%.3g)", sep, c.name.c_str(), adequacy::VerdictName(c.verdict), c.value);
    }
    sep = ", ";
  }
  std::printf("; %d of %zu drives failed a data check\n", pl.drives_failed, pl.drives.size());
  for (const auto& c : pl.checks)
    if (c.verdict == adequacy::Verdict::kFailed) std::printf("    failed %s: %s\n", c.name.c_str(), c.message.c_str());
}

}  // namespace

std::string YawValidationText(double rmse_radps, const char* none) {
  if (rmse_radps < 0) return none;
  return Fmt("%.4f deg/s", rmse_radps * 180 / M_PI);
}

std::string GateLine(const config::Config& config, const pipeline::Pipeline& pipeline) {
  const auto& gc = pipeline.gate().counters();
  const auto& acc = pipeline.accumulator();
  std::string line = "  gate:";
  for (int i = 0; i < gate::kNumVerdicts; ++i)
    if (gc.by_verdict[i])
      line += Fmt(" %s=%llu", gate::VerdictName(static_cast<gate::Verdict>(i)), static_cast<unsigned long long>(gc.by_verdict[i]));
  line += Fmt(" short_drive=%llu short_segment=%llu", static_cast<unsigned long long>(acc.counters().short_drive_samples),
              static_cast<unsigned long long>(acc.counters().short_segment_samples));
  const double accepted_h = static_cast<double>(gc.by_verdict[static_cast<int>(gate::Verdict::kAccepted)]) / config.sync.rate_hz / 3600.0;
  if (accepted_h > 0) {
    line += Fmt("\n  of %.3f accepted h, %.3f h (%.0f %%) reached the fit (drives >= %.1f km, stretches >= %.0f s, the "
                "window's %.0f h)",
                accepted_h, acc.window_hours(), 100 * acc.window_hours() / accepted_h, config.gate.min_drive_km,
                config.gate.min_segment_s, config.identification.window_h);
  }
  return line;
}

void PrintSummary(const config::Config& config, const pipeline::Pipeline& pipeline, const ReplayOutcome& outcome,
                  const std::string& report_path) {
  const auto& acc = pipeline.accumulator();
  int used = 0;
  for (const auto& dr : acc.drives()) used += dr.used ? 1 : 0;
  std::printf("%s: %zu drives (%d of >= %.1f km used), %.3f gated h, %llu frames, %llu malformed lines\n",
              outcome.name.c_str(), acc.drives().size(), used, config.gate.min_drive_km, acc.gated_hours(),
              static_cast<unsigned long long>(outcome.source.frames),
              static_cast<unsigned long long>(outcome.source.malformed));
  const pipeline::Estimate* fe = outcome.final_estimate ? &*outcome.final_estimate : nullptr;
  if (fe && HasEg(fe->fit)) {
    PrintEstimate(*fe, outcome);
    const auto& ss = fe->steady_state;
    std::printf("  steady-state check: EG = %s\n",
                ss.valid ? Fmt("%.4f deg/g", model::EgToDegPerG(ss.eg_rad_per_mps2)).c_str() : ss.reason.c_str());
    std::printf("  adequacy: %s — %s\n", adequacy::StateName(fe->adequacy.state), fe->adequacy.explanation.c_str());
  } else {
    std::string why = fe ? fe->fit.reason : "no gated data in the window";
    const auto& counters = acc.counters();
    const double accepted = static_cast<double>(
        pipeline.gate().counters().by_verdict[static_cast<int>(gate::Verdict::kAccepted)]);
    if (!fe && accepted > 0 && static_cast<double>(counters.short_segment_samples) > 0.5 * accepted) {
      why += Fmt(": %.0f %% of the accepted samples lie in stretches shorter than gate.min_segment_s (short_segment); "
                 "a noisy or vibrating sensor cut them (signals.<role>.lowpass_hz), or gaps in the signals",
                 100 * static_cast<double>(counters.short_segment_samples) / accepted);
    }
    std::printf("  no estimate: %s\n", why.c_str());
  }
  if (fe) PrintChecks(fe->plausibility);
  std::printf("%s\n", GateLine(config, pipeline).c_str());
  std::printf("  standstill a_y (road cross-slope): %.3f m/s^2 over %llu samples\n", pipeline.gate().standstill().mean_mps2(),
              static_cast<unsigned long long>(pipeline.gate().standstill().samples));
  if (fe) {
    std::printf("  standstill evidence: %zu stops (%.0f s) in the window", fe->standstill_stops, fe->standstill_seconds);
    for (const auto& sp : fe->standstill) {
      if (sp.param == "gyro_offset_radps") {
        std::printf("; gyro offset %.3f +- %.3f deg/s", sp.value * 180 / M_PI, sp.sd * 180 / M_PI);
      } else {
        std::printf("; mean a_y %.3f +- %.3f m/s^2 (accelerometer bias + cross-slope)", sp.value, sp.sd);
      }
    }
    if (fe->standstill.empty() && fe->standstill_stops < identify::Identifier::kMinStops)
      std::printf(" (fewer than %zu: no evidence used)", identify::Identifier::kMinStops);
    std::printf("\n");
  }
  const auto& tb = pipeline.time_base().counters();
  if (tb.spikes_dropped || tb.steps_back) {  // forward jumps are the gaps between drives: not faults
    std::printf("  clock: %llu frame(s) dropped as time spikes, %llu step(s) back (new time base), %llu jump(s) forward (gaps)\n",
                static_cast<unsigned long long>(tb.spikes_dropped), static_cast<unsigned long long>(tb.steps_back),
                static_cast<unsigned long long>(tb.steps_forward));
  }
  size_t incremental = 0;
  for (size_t i = 0; i + 1 < outcome.history.size(); ++i) incremental += outcome.history[i].fit.chunks_from_prior > 0 ? 1 : 0;
  std::printf("  time: %.1f s wall; %zu periodic identifications %.1f s beside the reading (%zu due while the last one "
              "ran), %.1f s of it waited for (%zu incremental, docs/incremental.md); final fit %.1f s (%s)\n",
              outcome.wall_s, outcome.history.empty() ? 0 : outcome.history.size() - 1, outcome.periodic_fit_wall_s,
              outcome.periodic_fits_queued, outcome.periodic_fit_wait_s, incremental, fe ? fe->fit.solve_seconds : 0.0,
              fe ? fe->fit.update.c_str() : "none");
  std::printf("  report: %s\n", report_path.c_str());
  if (outcome.periodic_fit_wait_s > 5 && outcome.periodic_fit_wait_s > 0.5 * outcome.wall_s) {
    std::printf("  note: %.0f of the %.0f s went to waiting for the re-identifications every identification.period_s, as "
                "the daemon does (the EG history above); --final-only identifies once at the end\n",
                outcome.periodic_fit_wait_s, outcome.wall_s);
  }
}

std::string EstimateMarkdown(const ReplayOutcome& outcome) {
  if (!outcome.final_estimate) return "No estimate: no gated data.\n";
  const pipeline::Estimate& e = *outcome.final_estimate;
  const identify::IdentificationResult& f = e.fit;
  if (!HasEg(f)) return "No estimate: " + f.reason + "\n";
  std::string md;
  md += f.valid ? Fmt("- EG = %.4f ± %.4f deg/g (%.6f ± %.6f rad/(m/s²)), %s: **valid**\n", f.eg_deg_per_g, f.eg_se_deg_per_g,
                      f.eg_rad_per_mps2, f.eg_se_rad_per_mps2, f.se_method.c_str())
                : Fmt("- EG = %.4f ± %.4f deg/g (%.6f ± %.6f rad/(m/s²)), %s: **NOT VALID** (%s)\n", f.eg_deg_per_g,
                      f.eg_se_deg_per_g, f.eg_rad_per_mps2, f.eg_se_rad_per_mps2, f.se_method.c_str(),
                      FailedNames(e.plausibility).empty() ? f.reason.c_str() : FailedNames(e.plausibility).c_str());
  md += Fmt("- adequacy: **%s** — %s\n", adequacy::StateName(e.adequacy.state), e.adequacy.explanation.c_str());
  md += Fmt("- RMSE train %.4f m/s², validation %.4f m/s²\n- gated hours %.3f (window %.3f)\n", f.rmse_train_mps2,
            f.rmse_validation_mps2, e.gated_hours, e.window_hours);
  if (e.steady_state.valid)
    md += Fmt("- steady-state check: EG = %.4f ± %.4f deg/g\n", model::EgToDegPerG(e.steady_state.eg_rad_per_mps2),
              model::EgToDegPerG(e.steady_state.eg_se));
  if (outcome.truth_eg) {
    md += Fmt("- truth (simulator): EG = %.4f deg/g; error %.2f %%\n", model::EgToDegPerG(*outcome.truth_eg),
              100 * (f.eg_rad_per_mps2 - *outcome.truth_eg) / *outcome.truth_eg);
  }
  md += "\n| parameter | value | σ | unit | note |\n|---|---|---|---|---|\n";
  for (int i = 0; i < model::kNumParams; ++i) {
    const auto& p = f.params[i];
    md += Fmt("| %s | %.5g | %.3g | %s | %s |\n", model::kParamNames[i], p.value, p.se, model::kParamUnits[i],
              p.fixed ? "fixed" : (p.at_bound ? "on bound" : ""));
  }
  for (const auto& p : f.effect_params) {
    md += Fmt("| %s | %.5g | %.3g | %s | %s |\n", p.name.c_str(), p.value, p.se, p.unit.c_str(),
              p.fixed ? "effect, fixed" : (p.at_bound ? "effect, on bound" : "effect"));
  }
  if (f.yaw_rate_output) {
    md += Fmt("\nOutputs: a_y and yaw rate. Yaw rate RMSE train %.4f deg/s, validation %s.\n", f.rmse_train_yaw_radps * 180 / M_PI,
              YawValidationText(f.rmse_validation_yaw_radps, "n/a").c_str());
  }
  md += "\nIdentifiability:\n";
  for (const auto& n : f.identifiability.notes) md += "- " + n + "\n";
  for (const auto& w : f.identifiability.weak) md += "- " + w.description + "\n";
  const auto& pl = e.plausibility;
  md += "\nChecks behind the validity (docs/monitoring.md):\n\n| check | verdict | value | informative data | |\n|---|---|---|---|---|\n";
  for (const auto& c : pl.checks) {
    md += Fmt("| %s | %s | %.4g | %.0f s | ", c.name.c_str(), adequacy::VerdictName(c.verdict), c.value, c.informative_s) +
          c.message + " |\n";
  }
  md += Fmt("\n%zu drives checked, %d failed a data check", pl.drives.size(), pl.drives_failed) +
        std::string(pl.drives_failed ? " (listed in estimate.json)" : "") + ".\n";
  return md;
}

}  // namespace ndsid::desk
