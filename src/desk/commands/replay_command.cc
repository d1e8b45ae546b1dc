// `ndsid replay`: recorded drives through the estimator. Without arguments, every bundled set
// in replay/ (each folder with drive.log[.gz], compared with its truth.yaml when present).
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "command_registry.h"
#include "html_report.h"
#include "ndsid/config/config.h"
#include "ndsid/config/truth_file.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/pipeline/pipeline.h"
#include "replay_runner.h"

namespace ndsid::desk {
namespace {
namespace fs = std::filesystem;

struct ReplayArgs {
  std::string config = std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml";
  std::vector<std::string> logs;
  std::string replay_dir = std::string(NDSID_SOURCE_DIR) + "/replay";
  std::string report_dir;
  bool final_only = false;
  bool use_config_logs = false;  // --config given without --log / --replay-dir: its source.logs
};

// A report folder name for a set of logs given with --log: the file name without its log and
// compression extensions, prefixed by its folder, so two drive.log.gz from different folders
// get different reports ("clean-drive", "steer_offset-drive"); "+N" counts further logs.
std::string LogSetName(const std::vector<std::string>& logs) {
  fs::path first = fs::absolute(logs.front()).lexically_normal();
  std::string stem = first.filename().string();
  for (const char* ext : {".gz", ".log", ".asc", ".blf", ".mf4", ".MF4", ".txt"}) {
    const std::string e = ext;
    if (stem.size() > e.size() && stem.compare(stem.size() - e.size(), e.size(), e) == 0) stem.resize(stem.size() - e.size());
  }
  const std::string parent = first.parent_path().filename().string();
  std::string name = parent.empty() ? stem : parent + "-" + stem;
  if (logs.size() > 1) name += "+" + std::to_string(logs.size() - 1);
  return name;
}

int Run(const ReplayArgs& a) {
  const config::Config cfg = config::LoadConfig(a.config);
  if (a.use_config_logs && cfg.source.logs.empty()) {
    // A live (socketcan) configuration has nothing to replay: say so instead of silently
    // replaying the bundled simulated sets.
    std::fprintf(stderr,
                 "ndsid replay: %s has source.type socketcan and no source.logs: give the logs to replay with --log "
                 "FILE... (or --replay-dir DIR)\n",
                 a.config.c_str());
    return kExitConfig;
  }
  const dbc::Database db = dbc::ParseDbcFile(cfg.dbc);
  const std::string report_root = a.report_dir.empty() ? cfg.report_dir : a.report_dir;

  struct Set {
    std::string name;
    std::vector<std::string> logs;
    std::string truth;
  };
  std::vector<Set> sets;
  if (!a.logs.empty()) {
    sets.push_back({LogSetName(a.logs), a.logs, ""});
  } else if (a.use_config_logs && !cfg.source.logs.empty()) {
    sets.push_back({fs::path(a.config).stem().string(), cfg.source.logs, ""});
  } else if (fs::exists(a.replay_dir)) {
    std::vector<fs::path> dirs;
    for (const auto& entry : fs::directory_iterator(a.replay_dir)) {
      if (entry.is_directory()) dirs.push_back(entry.path());
    }
    std::sort(dirs.begin(), dirs.end());
    for (const auto& d : dirs) {
      for (const char* name : {"drive.log.gz", "drive.log"}) {
        if (fs::exists(d / name)) {
          sets.push_back({d.filename().string(), {(d / name).string()},
                          fs::exists(d / "truth.yaml") ? (d / "truth.yaml").string() : ""});
          break;
        }
      }
    }
  }
  if (sets.empty()) sets.push_back({"config", cfg.source.logs, ""});

  int failures = 0;
  bool input_errors = false;
  for (const Set& set : sets) {
    pipeline::Pipeline pipeline(cfg, db);
    ReplayOptions opt;
    opt.logs = set.logs;
    opt.identify_periodically = !a.final_only;
    ReplayOutcome out = RunReplay(pipeline, cfg, opt);
    out.name = set.name;
    if (!set.truth.empty()) out.truth_eg = config::ReadTruthEg(set.truth);
    const std::string dir = (fs::path(report_root) / set.name).string();
    const std::string report = WriteReport(dir, cfg, pipeline, out);
    PrintSummary(cfg, pipeline, out, report);
    if (out.final_estimate) {  // the one-page report of what replay knows (html_report.h)
      HtmlReportInputs page;
      page.replay_dir = dir;
      page.truth_yaml = set.truth.empty() ? TruthBeside(set.logs) : set.truth;
      page.title = "ndsid replay: " + set.name;
      WriteCommandPage(dir, page, "  ");
    }
    if (!out.final_estimate || !out.final_estimate->fit.valid) ++failures;
    for (const std::string& e : out.input_errors) {
      std::fprintf(stderr, "ndsid replay: %s: log not read to its end: %s\n", set.name.c_str(), e.c_str());
      input_errors = true;
    }
  }
  if (input_errors) return kExitIo;
  return failures == 0 ? 0 : 1;
}

void Register(CLI::App& parent, int& exit_code) {
  auto args = std::make_shared<ReplayArgs>();
  auto* cmd = parent.add_subcommand(
      "replay", "Replay recorded drives (CAN logs: candump, ASC, BLF, MF4) through the estimator: EG ± sigma, adequacy, report");
  auto* config_opt = cmd->add_option("--config", args->config,
                                     "Vehicle configuration (YAML); given alone, its source.logs are replayed")
                         ->capture_default_str();
  auto* log_opt = cmd->add_option("--log", args->logs,
                                  "Log files to replay as one set (default: the --config's source.logs when --config "
                                  "is given, else every set in --replay-dir)");
  auto* dir_opt = cmd->add_option("--replay-dir", args->replay_dir, "Folder of bundled sets (one subfolder each)")
                      ->capture_default_str();
  cmd->add_option("--report", args->report_dir, "Report folder (default: report_dir of the configuration)");
  cmd->add_flag("--final-only", args->final_only, "Identify once at the end instead of every identification.period_s");
  cmd->callback([args, &exit_code, config_opt, log_opt, dir_opt] {
    args->use_config_logs = config_opt->count() > 0 && log_opt->count() == 0 && dir_opt->count() == 0;
    exit_code = Run(*args);
  });
}

}  // namespace
}  // namespace ndsid::desk

NDSID_REGISTER_COMMAND(replay, ndsid::desk::Register);
