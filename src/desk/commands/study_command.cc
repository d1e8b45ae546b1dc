// `ndsid study`: the study's subset analysis (Reicherts et al. 2021, Fig. 6 and Table 2).
// Complete drives are split at random into independent sets of growing size (single drives,
// then sets of H gated hours, then all); each set is identified on its own and validated on
// drives held out from every set. EG's spread per set size shows when more data stop moving it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>

#include "command_registry.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/config/config.h"
#include "ndsid/config/truth_file.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/pipeline/pipeline.h"
#include "desk_script.h"
#include "replay_runner.h"

namespace ndsid::desk {
namespace {
namespace fs = std::filesystem;

struct StudyArgs {
  std::string config = std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml";
  std::vector<std::string> logs;
  std::vector<double> hours{1.0, 2.0, 5.0};
  int max_single = 20;
  double validation_fraction = 0.15;
  uint64_t seed = 1;
  std::string out;
  std::string truth;
};

struct SetResult {
  std::string kind;
  double hours = 0;
  double eg_deg_per_g = 0, eg_se_deg_per_g = 0, rmse_validation = 0;
  bool valid = false;
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

int Run(const StudyArgs& a) {
  // Arguments first: nothing is replayed for a run that cannot finish.
  for (double h : a.hours) {
    if (!(h > 0) || !std::isfinite(h)) throw ConfigError("--hours: set sizes must be positive hours, got " + std::to_string(h));
  }
  if (!(a.validation_fraction > 0 && a.validation_fraction < 1)) throw ConfigError("--validation-fraction must be in (0, 1)");
  if (a.max_single < 0) throw ConfigError("--max-single must be >= 0");
  config::Config cfg = config::LoadConfig(a.config);
  cfg.identification.window_h = 1e9;  // keep every drive: the study splits them itself
  const dbc::Database db = dbc::ParseDbcFile(cfg.dbc);
  pipeline::Pipeline pipeline(cfg, db);
  ReplayOptions opt;
  opt.logs = a.logs;
  opt.identify_periodically = false;
  RunReplay(pipeline, cfg, opt);

  // Drives with their segments and gated hours.
  std::map<int64_t, identify::SegmentList> by_drive;
  std::map<int64_t, double> hours_of;
  for (const auto& seg : pipeline.accumulator().window()) {
    by_drive[seg->drive_id].push_back(seg.get());
    hours_of[seg->drive_id] += seg->duration_s() / 3600.0;
  }
  std::vector<int64_t> drives;
  for (const auto& [id, segs] : by_drive) drives.push_back(id);
  if (drives.size() < 3) throw ConfigError("study: need at least 3 usable drives, found " + std::to_string(drives.size()));
  std::mt19937_64 rng(a.seed);
  std::shuffle(drives.begin(), drives.end(), rng);
  // Validation drives, held out from every set.
  const size_t n_val = std::max<size_t>(1, static_cast<size_t>(a.validation_fraction * drives.size()));
  identify::SegmentList validation;
  for (size_t i = 0; i < n_val; ++i)
    for (auto* s : by_drive[drives[i]]) validation.push_back(s);
  const std::vector<int64_t> pool(drives.begin() + static_cast<long>(n_val), drives.end());
  double pool_hours = 0;
  for (int64_t d : pool) pool_hours += hours_of[d];

  const identify::Identifier& id = pipeline.identifier();
  std::vector<SetResult> results;
  auto fit = [&](const std::string& kind, double target_h, const std::vector<int64_t>& set) {
    identify::SegmentList training;
    double h = 0;
    for (int64_t d : set) {
      for (auto* s : by_drive[d]) training.push_back(s);
      h += hours_of[d];
    }
    const auto r = id.Identify(training, validation, std::optional<std::vector<double>>{});
    results.push_back({kind, h, r.eg_deg_per_g, r.eg_se_deg_per_g, r.rmse_validation_mps2, r.valid});
    std::fprintf(stderr, "  %-8s %5.2f h: EG %.4f ± %.4f deg/g, validation RMSE %.4f%s\n", kind.c_str(), h,
                 r.eg_deg_per_g, r.eg_se_deg_per_g, r.rmse_validation_mps2, r.valid ? "" : " (not valid)");
  };
  // Single drives.
  for (size_t i = 0; i < pool.size() && static_cast<int>(i) < a.max_single; ++i) fit("SD", 0, {pool[i]});
  // Independent sets of H hours: consecutive drives of the shuffled pool until each reaches H.
  for (double H : a.hours) {
    if (H > pool_hours) continue;
    std::vector<int64_t> set;
    double h = 0;
    char kind[32];
    std::snprintf(kind, sizeof kind, "H%g", H);
    for (int64_t d : pool) {
      set.push_back(d);
      h += hours_of[d];
      if (h >= H) {
        fit(kind, H, set);
        set.clear();
        h = 0;
      }
    }
  }
  fit("AD", pool_hours, pool);

  // Table per set size: EG min / median / max, spread, validation RMSE (the study's Table 2).
  const std::optional<double> truth_eg = a.truth.empty() ? std::nullopt : config::ReadTruthEg(a.truth);
  std::string table =
      "set   sets  hours/set  EG min    EG median  EG max    spread%   RMSE_val min  median  max     mean\n";
  std::vector<std::string> kinds;
  for (const auto& r : results)
    if (std::find(kinds.begin(), kinds.end(), r.kind) == kinds.end()) kinds.push_back(r.kind);
  std::string csv = "set,hours,eg_deg_per_g,eg_se_deg_per_g,rmse_validation,valid\n";
  // The same table as the terminal's, machine-readable (ndsid.study reads it as a DataFrame).
  std::string summary_csv =
      "set,sets,hours_per_set,eg_min,eg_median,eg_max,spread_pct,rmse_validation_min,rmse_validation_median,"
      "rmse_validation_max,rmse_validation_mean\n";
  for (const auto& r : results) {
    char line[160];
    std::snprintf(line, sizeof line, "%s,%.4f,%.6f,%.6f,%.6f,%d\n", r.kind.c_str(), r.hours, r.eg_deg_per_g,
                  r.eg_se_deg_per_g, r.rmse_validation, r.valid ? 1 : 0);
    csv += line;
  }
  for (const auto& k : kinds) {
    std::vector<double> eg, rm, hrs;
    for (const auto& r : results) {
      if (r.kind != k || !r.valid) continue;
      eg.push_back(r.eg_deg_per_g);
      rm.push_back(r.rmse_validation);
      hrs.push_back(r.hours);
    }
    if (eg.empty()) continue;
    const double med = Median(eg), lo = *std::min_element(eg.begin(), eg.end()), hi = *std::max_element(eg.begin(), eg.end());
    double mean_rm = 0;
    for (double v : rm) mean_rm += v / rm.size();
    char line[256];
    std::snprintf(line, sizeof line, "%-5s %4zu  %8.2f  %8.4f  %8.4f  %8.4f  %7.2f   %10.4f  %7.4f  %7.4f  %7.4f\n",
                  k.c_str(), eg.size(), Median(hrs), lo, med, hi, 100 * (hi - lo) / std::abs(med),
                  *std::min_element(rm.begin(), rm.end()), Median(rm), *std::max_element(rm.begin(), rm.end()), mean_rm);
    table += line;
    std::snprintf(line, sizeof line, "%s,%zu,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f\n", k.c_str(), eg.size(),
                  Median(hrs), lo, med, hi, 100 * (hi - lo) / std::abs(med), *std::min_element(rm.begin(), rm.end()),
                  Median(rm), *std::max_element(rm.begin(), rm.end()), mean_rm);
    summary_csv += line;
  }
  std::printf("%s", table.c_str());
  if (truth_eg) std::printf("truth EG (simulator): %.4f deg/g\n", model::EgToDegPerG(*truth_eg));
  const std::string out = a.out.empty() ? cfg.report_dir + "/study" : a.out;
  fs::create_directories(out);
  WriteFileAtomically(out + "/study.csv", csv);
  WriteFileAtomically(out + "/study_table.txt", table);
  WriteFileAtomically(out + "/study_summary.csv", summary_csv);
  if (truth_eg) {
    char line[96];
    std::snprintf(line, sizeof line, "{\"truth_eg_deg_per_g\": %.10g}\n", model::EgToDegPerG(*truth_eg));
    WriteFileAtomically(out + "/study_truth.json", line);
  }
  std::vector<std::string> plot_args = {out};
  if (truth_eg) plot_args.push_back(std::to_string(model::EgToDegPerG(*truth_eg)));
  std::string why_not;
  if (RunDeskScript("plot_study.py", plot_args, {}, &why_not)) std::printf("plot: %s/study.png\n", out.c_str());
  std::printf("report: %s/study.csv\n", out.c_str());
  return 0;
}

void Register(CLI::App& parent, int& exit_code) {
  auto a = std::make_shared<StudyArgs>();
  auto* cmd = parent.add_subcommand("study", "The study's subset analysis: EG spread and validation RMSE per data-set size");
  cmd->add_option("--config", a->config, "Vehicle configuration (YAML)")->capture_default_str();
  cmd->add_option("--log", a->logs, "Logs to study (default: the configuration's source)");
  cmd->add_option("--hours", a->hours, "Set sizes in gated hours, comma-separated (besides single drives and all)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--max-single", a->max_single, "Single drives to identify at most")->capture_default_str();
  cmd->add_option("--validation-fraction", a->validation_fraction, "Share of drives held out for validation")->capture_default_str();
  cmd->add_option("--seed", a->seed, "Seed of the random split")->capture_default_str();
  cmd->add_option("--truth", a->truth, "Simulator truth.yaml to compare with");
  cmd->add_option("--out", a->out, "Output folder (default: <report_dir>/study)");
  cmd->callback([a, &exit_code] { exit_code = Run(*a); });
}

}  // namespace
}  // namespace ndsid::desk

NDSID_REGISTER_COMMAND(study, ndsid::desk::Register);
