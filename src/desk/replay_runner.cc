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
#include "replay_summary.h"
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
    const pipeline::Estimate& e = pipeline.Accept(*pending->snap, std::move(fit), &pending->data_checks, pending->choice.get());
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
  md += EstimateMarkdown(outcome);
  md += "\nFiles: `estimate.json`, `eg_history.csv`, `drives.csv`, `gate.csv`, `coverage.csv`";
  // Plots through the project's venv (optional: the numbers above do not depend on it).
  std::string why_not;
  if (RunDeskScript("plot_report.py", {d.string()}, {}, &why_not)) md += ", `eg_history.png`, `coverage.png`";
  md += "\n";
  WriteText(d / "report.md", md);
  return (d / "report.md").string();
}

}  // namespace ndsid::desk
