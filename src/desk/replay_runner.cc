#include "replay_runner.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>

#include "ndsid/can/frame_log.h"
#include "ndsid/pipeline/estimate_codec.h"
#include "desk_script.h"
#include "progress.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/common/error.h"

namespace ndsid::desk {
namespace fs = std::filesystem;

ReplayOutcome RunReplay(pipeline::Pipeline& pipeline, const config::Config& config, const ReplayOptions& options) {
  ReplayOutcome out;
  const auto t_start = std::chrono::steady_clock::now();
  const auto& logs = options.logs.empty() ? config.source.logs : options.logs;
  std::vector<can::CanFrame> frames(256);
  for (const std::string& path : logs) can::DetectLogFormat(path);  // every file readable before any work
  // Progress: the logs weighted by their size on disk.
  std::vector<double> sizes;
  double total_size = 0;
  for (const std::string& path : logs) {
    std::error_code ec;
    sizes.push_back(static_cast<double>(fs::file_size(path, ec)));
    if (ec) sizes.back() = 0;
    total_size += sizes.back();
  }
  Progress progress("replay");
  // Periodic fits run on a worker beside the reading, as in the daemon, one at a time: each is
  // accepted before the next starts (the next fit's warm start and prior come from it). A fit due
  // while the last one still runs takes its snapshot then and waits in `queued` while the reading
  // goes on; it starts when the fits before it have been accepted. So the snapshots, fits and
  // estimates are those of fitting in line, and the reading waits for no fit.
  std::optional<pipeline::FitJob> pending;
  std::deque<std::shared_ptr<const pipeline::WindowSnapshot>> queued;
  auto accept_pending = [&] {  // waits for the running fit (rethrows its error) and records it
    if (!pending) return;
    const auto t_wait = std::chrono::steady_clock::now();
    identify::IdentificationResult fit = pending->result.get();
    out.periodic_fit_wait_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_wait).count();
    out.periodic_fit_wall_s += pending->fit_s->load();
    const pipeline::Estimate& e = pipeline.Accept(*pending->snap, std::move(fit), &pending->data_checks);
    pending.reset();
    progress.Done();  // the log line on a line of its own
    spdlog::info("{:.2f} gated h: EG {:.3f} ± {:.3f} deg/g, {}", e.gated_hours, e.fit.eg_deg_per_g, e.fit.eg_se_deg_per_g,
                 adequacy::StateName(e.adequacy.state));
  };
  // Accepts the running fit once it has ended (with wait: when it ends) and starts the next
  // queued one, until none has ended or none is left.
  auto pump = [&](bool wait) {
    while (pending && (wait || pending->result.wait_for(std::chrono::seconds(0)) == std::future_status::ready)) {
      accept_pending();
      if (queued.empty()) break;
      pending = pipeline.StartFit(std::move(queued.front()));
      queued.pop_front();
    }
  };
  double size_done = 0, data_s_done = 0;
  uint64_t frames_done = 0;
  for (size_t li = 0; li < logs.size(); ++li) {
    const std::string& path = logs[li];
    const std::unique_ptr<can::FrameLog> log = can::OpenFrameLog(path);
    can::FrameLog& reader = *log;
    spdlog::info("replaying {}", reader.Describe());
    int64_t first_ns = INT64_MIN, last_ns = INT64_MIN;
    for (;;) {
      const can::ReadResult r = reader.Read(frames, 0);
      pipeline.ProcessFrames(std::span<const can::CanFrame>(frames.data(), r.count), reader.bus_names());
      if (progress.enabled() && r.count > 0) {
        if (first_ns == INT64_MIN) first_ns = frames[0].timestamp_ns;
        last_ns = frames[r.count - 1].timestamp_ns;
        const double f = reader.fraction_read();
        const double done = total_size > 0 && f >= 0 ? (size_done + f * sizes[li]) / total_size : -1.0;
        progress.Update(done, frames_done + reader.counters().frames, data_s_done + 1e-9 * static_cast<double>(last_ns - first_ns));
      }
      if (options.identify_periodically) {
        pump(false);
        const pipeline::WindowSnapshot* last = !queued.empty() ? queued.back().get() : pending ? pending->snap.get() : nullptr;
        if (pipeline.IdentificationDue(last)) {
          if (pending) {
            queued.push_back(std::make_shared<const pipeline::WindowSnapshot>(pipeline.Snapshot()));
            ++out.periodic_fits_queued;
          } else {
            pending = pipeline.StartFit();
          }
        }
      }
      if (r.state == can::SourceState::kEnd) break;
    }
    if (!reader.io_error().empty()) out.input_errors.push_back(path + ": " + reader.io_error());
    const auto& c = reader.counters();
    if (!reader.io_error().empty()) {  // a truncated or corrupt file is never taken as complete
      throw Error(path + ": reading stopped after " + std::to_string(c.frames) + " frames: " + reader.io_error());
    }
    out.source.frames += c.frames;
    size_done += sizes[li];
    frames_done += c.frames;
    if (first_ns != INT64_MIN) data_s_done += 1e-9 * static_cast<double>(last_ns - first_ns);
    out.source.malformed += c.malformed;
    out.source.error_frames += c.error_frames;
    out.source.time_backwards += c.time_backwards;
  }
  progress.Done();
  pump(true);  // before Finish: the last periodic fit saw the data up to its snapshot only
  pipeline.Finish();
  if (!pipeline.accumulator().window().empty()) pipeline.IdentifyNow(true);  // the final fit: the whole window's optimum
  out.history = pipeline.history();
  // The final fit, valid or not (a replay reports what its data give; the daemon keeps
  // publishing its last valid estimate beside a not-valid one).
  if (!out.history.empty()) {
    out.final_estimate = out.history.back();
  } else if (pipeline.last_estimate()) {
    out.final_estimate = *pipeline.last_estimate();
  }
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return out;
}

namespace {

// The estimate's document (pipeline::EstimateToJson, the form the daemon's state keeps) with
// the run's vehicle and effects.
nlohmann::json EstimateJson(const config::Config& config, const pipeline::Estimate& e) {
  nlohmann::json j = pipeline::EstimateToJson(e);
  j["vehicle"] = config.vehicle.name;
  j["effects"] = config.model_effects;
  return j;
}

void WriteText(const fs::path& p, const std::string& text) { WriteFileAtomically(p.string(), text); }

// The held-out yaw-rate RMSE in deg/s, or `none` without held-out data (-1).
std::string YawValidationText(double rmse_radps, const char* none) {
  if (rmse_radps < 0) return none;
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.4f deg/s", rmse_radps * 180 / M_PI);
  return buf;
}

}  // namespace

std::string WriteReport(const std::string& dir, const config::Config& config, const pipeline::Pipeline& pipeline,
                        const ReplayOutcome& outcome) {
  fs::create_directories(dir);
  const fs::path d(dir);
  // EG history.
  {
    std::string csv = "gated_hours,eg_rad_per_mps2,eg_se_rad_per_mps2,eg_deg_per_g,eg_se_deg_per_g,rmse_train,rmse_validation,state,valid\n";
    char line[256];
    for (const pipeline::Estimate& e : outcome.history) {
      std::snprintf(line, sizeof line, "%.4f,%.8g,%.8g,%.6g,%.6g,%.6g,%.6g,%s,%d\n", e.gated_hours, e.fit.eg_rad_per_mps2,
                    e.fit.eg_se_rad_per_mps2, e.fit.eg_deg_per_g, e.fit.eg_se_deg_per_g, e.fit.rmse_train_mps2,
                    e.fit.rmse_validation_mps2, adequacy::StateName(e.adequacy.state), e.fit.valid ? 1 : 0);
      csv += line;
    }
    WriteText(d / "eg_history.csv", csv);
  }
  // Drives.
  {
    std::string csv = "drive,start_s,duration_s,distance_km,gated_s,used\n";
    char line[256];
    for (const auto& dr : pipeline.accumulator().drives()) {
      std::snprintf(line, sizeof line, "%lld,%.3f,%.1f,%.3f,%.1f,%d\n", static_cast<long long>(dr.drive_id),
                    dr.start_ns * 1e-9, (dr.end_ns - dr.start_ns) * 1e-9, dr.distance_km, dr.gated_s, dr.used ? 1 : 0);
      csv += line;
    }
    WriteText(d / "drives.csv", csv);
  }
  // Gate counters.
  {
    std::string csv = "reason,samples\n";
    const auto& gc = pipeline.gate().counters();
    for (int i = 0; i < gate::kNumVerdicts; ++i) {
      csv += std::string(gate::VerdictName(static_cast<gate::Verdict>(i))) + "," + std::to_string(gc.by_verdict[i]) + "\n";
    }
    const auto& ac = pipeline.accumulator().counters();
    csv += "short_drive," + std::to_string(ac.short_drive_samples) + "\n";
    csv += "short_segment," + std::to_string(ac.short_segment_samples) + "\n";
    WriteText(d / "gate.csv", csv);
  }
  // Coverage (g-g and v-a_y histograms) for the plots.
  {
    const auto& cov = pipeline.accumulator().coverage();
    std::string csv = "histogram,x_lo,y_lo,count\n";
    char line[128];
    for (const auto* h : {&cov.gg(), &cov.v_ay()}) {
      const char* name = (h == &cov.gg()) ? "gg" : "v_ay";
      for (int ix = 0; ix < h->nx; ++ix)
        for (int iy = 0; iy < h->ny; ++iy) {
          const double c = h->counts[static_cast<size_t>(ix * h->ny + iy)];
          if (c <= 0) continue;
          std::snprintf(line, sizeof line, "%s,%.3f,%.3f,%.0f\n", name, h->x_min + (h->x_max - h->x_min) * ix / h->nx,
                        h->y_min + (h->y_max - h->y_min) * iy / h->ny, c);
          csv += line;
        }
    }
    WriteText(d / "coverage.csv", csv);
  }
  nlohmann::json j = outcome.final_estimate ? EstimateJson(config, *outcome.final_estimate) : nlohmann::json::object();
  if (outcome.truth_eg) j["truth_eg_rad_per_mps2"] = *outcome.truth_eg;
  j["frames"] = outcome.source.frames;
  {
    const auto& tb = pipeline.time_base().counters();
    j["clock"] = {{"spikes_dropped", tb.spikes_dropped}, {"steps_back", tb.steps_back}, {"steps_forward", tb.steps_forward},
                  {"shift_ns", tb.shift_ns}};
  }
  j["malformed_lines"] = outcome.source.malformed;
  WriteText(d / "estimate.json", j.dump(2) + "\n");

  // Markdown summary.
  std::string md = "# ndsid replay: " + outcome.name + "\n\n";
  char buf[512];
  if (outcome.final_estimate && outcome.final_estimate->fit.valid) {
    const auto& e = *outcome.final_estimate;
    std::snprintf(buf, sizeof buf,
                  "- EG = %.4f ± %.4f deg/g (%.6f ± %.6f rad/(m/s²)), %s\n- adequacy: **%s** — %s\n"
                  "- RMSE train %.4f m/s², validation %.4f m/s²\n- gated hours %.3f (window %.3f)\n",
                  e.fit.eg_deg_per_g, e.fit.eg_se_deg_per_g, e.fit.eg_rad_per_mps2, e.fit.eg_se_rad_per_mps2,
                  e.fit.se_method.c_str(), adequacy::StateName(e.adequacy.state), e.adequacy.explanation.c_str(),
                  e.fit.rmse_train_mps2, e.fit.rmse_validation_mps2, e.gated_hours, e.window_hours);
    md += buf;
    if (outcome.truth_eg) {
      std::snprintf(buf, sizeof buf, "- truth (simulator): EG = %.4f deg/g; error %.2f %%\n",
                    model::EgToDegPerG(*outcome.truth_eg),
                    100 * (e.fit.eg_rad_per_mps2 - *outcome.truth_eg) / *outcome.truth_eg);
      md += buf;
    }
    md += "\n| parameter | value | σ | unit | note |\n|---|---|---|---|---|\n";
    for (int i = 0; i < model::kNumParams; ++i) {
      const auto& p = e.fit.params[i];
      std::snprintf(buf, sizeof buf, "| %s | %.5g | %.3g | %s | %s |\n", model::kParamNames[i], p.value, p.se,
                    model::kParamUnits[i], p.fixed ? "fixed" : (p.at_bound ? "on bound" : ""));
      md += buf;
    }
    for (const auto& p : e.fit.effect_params) {
      std::snprintf(buf, sizeof buf, "| %s | %.5g | %.3g | %s | %s |\n", p.name.c_str(), p.value, p.se, p.unit.c_str(),
                    p.fixed ? "effect, fixed" : (p.at_bound ? "effect, on bound" : "effect"));
      md += buf;
    }
    if (e.fit.yaw_rate_output) {
      std::snprintf(buf, sizeof buf, "\nOutputs: a_y and yaw rate. Yaw rate RMSE train %.4f deg/s, validation %s.\n",
                    e.fit.rmse_train_yaw_radps * 180 / M_PI, YawValidationText(e.fit.rmse_validation_yaw_radps, "n/a").c_str());
      md += buf;
    }
    md += "\nIdentifiability:\n";
    for (const auto& n : e.fit.identifiability.notes) md += "- " + n + "\n";
    for (const auto& w : e.fit.identifiability.weak) md += "- " + w.description + "\n";
  } else if (outcome.final_estimate && std::isfinite(outcome.final_estimate->fit.eg_deg_per_g) &&
             outcome.final_estimate->fit.eg_se_deg_per_g > 0) {
    const auto& f = outcome.final_estimate->fit;
    std::snprintf(buf, sizeof buf, "- **EG = %.4f ± %.4f deg/g: NOT VALID** — ", f.eg_deg_per_g, f.eg_se_deg_per_g);
    md += buf + f.reason + "\n";
  } else {
    md += "No valid estimate: " +
          (outcome.final_estimate ? outcome.final_estimate->fit.reason : std::string("no gated data")) + "\n";
  }
  if (outcome.final_estimate) {
    const auto& pl = outcome.final_estimate->plausibility;
    md += "\nPlausibility (docs/monitoring.md):\n\n| check | verdict | value | informative data | |\n|---|---|---|---|---|\n";
    for (const auto& c : pl.checks) {
      std::snprintf(buf, sizeof buf, "| %s | %s | %.4g | %.0f s | ", c.name.c_str(), adequacy::VerdictName(c.verdict), c.value,
                    c.informative_s);
      md += buf + c.message + " |\n";
    }
    std::snprintf(buf, sizeof buf, "\n%zu drives checked, %d failed a data check", pl.drives.size(), pl.drives_failed);
    md += buf + std::string(pl.drives_failed ? " (listed in estimate.json)" : "") + ".\n";
  }
  md += "\nFiles: `estimate.json`, `eg_history.csv`, `drives.csv`, `gate.csv`, `coverage.csv`";
  // Plots through the project's venv (optional: the numbers above do not depend on it).
  std::string why_not;
  if (RunDeskScript("plot_report.py", {d.string()}, {}, &why_not)) md += ", `eg_history.png`, `coverage.png`";
  md += "\n";
  WriteText(d / "report.md", md);
  return (d / "report.md").string();
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
  if (outcome.final_estimate && outcome.final_estimate->fit.valid) {
    const auto& e = *outcome.final_estimate;
    std::printf("  EG = %.4f ± %.4f deg/g   (%.6f ± %.6f rad/(m/s^2), 1 sigma)\n", e.fit.eg_deg_per_g,
                e.fit.eg_se_deg_per_g, e.fit.eg_rad_per_mps2, e.fit.eg_se_rad_per_mps2);
    if (outcome.truth_eg) {
      std::printf("  truth EG = %.4f deg/g (simulator); error %+.2f %% = %+.1f sigma\n",
                  model::EgToDegPerG(*outcome.truth_eg),
                  100 * (e.fit.eg_rad_per_mps2 - *outcome.truth_eg) / *outcome.truth_eg,
                  (e.fit.eg_rad_per_mps2 - *outcome.truth_eg) / e.fit.eg_se_rad_per_mps2);
    }
    std::printf("  is = %.3f, lv = %.3f m, cv = %.0f N/rad, ch = %.0f N/rad, Jz = %.0f kg m^2, m = %.0f kg (%s)\n",
                e.fit.params[model::kSteerRatio].value, e.fit.params[model::kCgToFront].value,
                e.fit.params[model::kStiffFront].value, e.fit.params[model::kStiffRear].value,
                e.fit.params[model::kYawInertia].value, e.fit.params[model::kMass].value,
                e.fit.params[model::kMass].fixed ? "fixed" : "identified");
    char validation[48] = "n/a (no held-out drive)", steady[48];  // rounded, never cut
    if (e.fit.rmse_validation_mps2 >= 0) std::snprintf(validation, sizeof validation, "%.4f m/s^2", e.fit.rmse_validation_mps2);
    std::snprintf(steady, sizeof steady, "%.4f deg/g", model::EgToDegPerG(e.steady_state.eg_rad_per_mps2));
    std::printf("  RMSE train %.4f m/s^2, validation %s\n", e.fit.rmse_train_mps2, validation);
    if (e.fit.yaw_rate_output) {
      std::printf("  yaw rate (fitted too): RMSE train %.4f deg/s, validation %s\n", e.fit.rmse_train_yaw_radps * 180 / M_PI,
                  YawValidationText(e.fit.rmse_validation_yaw_radps, "n/a (no held-out drive)").c_str());
    }
    for (const auto& p : e.fit.effect_params)
      std::printf("  %s = %.5g ± %.2g %s%s\n", p.name.c_str(), p.value, p.se, p.unit.c_str(), p.fixed ? " (fixed)" : "");
    std::printf("  steady-state check: EG = %s\n", e.steady_state.valid ? steady : e.steady_state.reason.c_str());
    std::printf("  adequacy: %s — %s\n", adequacy::StateName(e.adequacy.state), e.adequacy.explanation.c_str());
  } else if (outcome.final_estimate && std::isfinite(outcome.final_estimate->fit.eg_deg_per_g) &&
             outcome.final_estimate->fit.eg_se_deg_per_g > 0) {
    const auto& f = outcome.final_estimate->fit;
    std::printf("  EG = %.4f ± %.4f deg/g   NOT VALID: %s\n", f.eg_deg_per_g, f.eg_se_deg_per_g, f.reason.c_str());
  } else {
    std::printf("  no valid estimate: %s\n",
                outcome.final_estimate ? outcome.final_estimate->fit.reason.c_str() : "no gated data in the window");
  }
  if (outcome.final_estimate) {
    std::printf("  plausibility:");
    const char* sep = " ";
    for (const auto& c : outcome.final_estimate->plausibility.checks) {
      if (c.verdict == adequacy::Verdict::kSkipped) {
        std::printf("%s%s skipped", sep, c.name.c_str());
      } else {
        std::printf("%s%s %s (%.3g)", sep, c.name.c_str(), adequacy::VerdictName(c.verdict), c.value);
      }
      sep = ", ";
    }
    std::printf("; %d of %zu drives failed a data check\n", outcome.final_estimate->plausibility.drives_failed,
                outcome.final_estimate->plausibility.drives.size());
  }
  const auto& gc = pipeline.gate().counters();
  std::printf("  gate:");
  for (int i = 0; i < gate::kNumVerdicts; ++i) {
    if (gc.by_verdict[i]) std::printf(" %s=%llu", gate::VerdictName(static_cast<gate::Verdict>(i)),
                                      static_cast<unsigned long long>(gc.by_verdict[i]));
  }
  std::printf(" short_drive=%llu\n", static_cast<unsigned long long>(acc.counters().short_drive_samples));
  std::printf("  standstill a_y (road cross-slope): %.3f m/s^2 over %llu samples\n", pipeline.gate().standstill().mean_mps2(),
              static_cast<unsigned long long>(pipeline.gate().standstill().samples));
  if (outcome.final_estimate) {
    const pipeline::Estimate& fe = *outcome.final_estimate;
    std::printf("  standstill evidence: %zu stops (%.0f s) in the window", fe.standstill_stops, fe.standstill_seconds);
    for (const auto& sp : fe.standstill) {
      if (sp.param == "gyro_offset_radps") {
        std::printf("; gyro offset %.3f +- %.3f deg/s", sp.value * 180 / M_PI, sp.sd * 180 / M_PI);
      } else {
        std::printf("; mean a_y %.3f +- %.3f m/s^2 (accelerometer bias + cross-slope)", sp.value, sp.sd);
      }
    }
    if (fe.standstill.empty() && fe.standstill_stops < identify::Identifier::kMinStops)
      std::printf(" (fewer than %zu: no evidence used)", identify::Identifier::kMinStops);
    std::printf("\n");
  }
  const auto& tb = pipeline.time_base().counters();
  if (tb.spikes_dropped || tb.steps_back) {  // forward jumps are the gaps between drives: not faults
    std::printf("  clock: %llu frame(s) dropped as time spikes, %llu step(s) back (new time base), %llu jump(s) forward (gaps)\n",
                static_cast<unsigned long long>(tb.spikes_dropped), static_cast<unsigned long long>(tb.steps_back),
                static_cast<unsigned long long>(tb.steps_forward));
  }
  {
    size_t incremental = 0;
    for (size_t i = 0; i + 1 < outcome.history.size(); ++i) incremental += outcome.history[i].fit.chunks_from_prior > 0 ? 1 : 0;
    const double final_s = outcome.final_estimate ? outcome.final_estimate->fit.solve_seconds : 0.0;
    std::printf("  time: %.1f s wall; %zu periodic identifications %.1f s beside the reading (%zu due while the last one "
                "ran), %.1f s of it waited for (%zu incremental, docs/incremental.md); final fit %.1f s (%s)\n",
                outcome.wall_s, outcome.history.empty() ? 0 : outcome.history.size() - 1, outcome.periodic_fit_wall_s,
                outcome.periodic_fits_queued, outcome.periodic_fit_wait_s, incremental, final_s,
                outcome.final_estimate ? outcome.final_estimate->fit.update.c_str() : "none");
  }
  std::printf("  report: %s\n", report_path.c_str());
  if (outcome.periodic_fit_wait_s > 5 && outcome.periodic_fit_wait_s > 0.5 * outcome.wall_s) {
    std::printf("  note: %.0f of the %.0f s went to waiting for the re-identifications every identification.period_s, as "
                "the daemon does (the EG history above); --final-only identifies once at the end\n",
                outcome.periodic_fit_wait_s, outcome.wall_s);
  }
}

}  // namespace ndsid::desk
