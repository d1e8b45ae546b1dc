// `ndsid simulate`: naturalistic drives of a car with known parameters and switchable hidden
// effects, written as a candump log (encoded with the DBC), a truth file and optionally a CSV.
#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "command_registry.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/common/error.h"
#include "ndsid/config/simulation_config.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/sim/candump_writer.h"
#include "ndsid/sim/simulator.h"
#include "ndsid/sim/truth_writer.h"

namespace {

struct SimulateOptions {
  std::string config_path;
  std::string dbc_path = std::string(NDSID_SOURCE_DIR) + "/dbc/ndsid_example.dbc";  // not the working directory's
  std::string out_dir;
  std::vector<std::string> effects;
  uint64_t seed = 0;
  double hours = 0.0;
  int drives = 0;
  bool signals_csv = false;
  bool gzip = false;
  bool no_log = false;
};

std::string EffectHelp() {
  std::ostringstream o;
  o << "Hidden effect name=value, repeatable. Names:\n";
  for (const auto& e : ndsid::config::EffectTable())
    o << "  " << e.name << " [" << e.unit << "] " << e.meaning << " (typical " << e.typical << ")\n";
  o << "  (YAML also: effects.mass_schedule_kg: [dm0, dm1, ...] per drive, cycled)";
  return o.str();
}

std::string CommandLine(const SimulateOptions& o, CLI::App* cmd) {
  std::ostringstream c;
  c << "ndsid simulate";
  if (!o.config_path.empty()) c << " --config " << o.config_path;
  if (cmd->count("--dbc")) c << " --dbc " << o.dbc_path;
  if (cmd->count("--seed")) c << " --seed " << o.seed;
  if (cmd->count("--hours")) c << " --hours " << o.hours;
  if (cmd->count("--drives")) c << " --drives " << o.drives;
  for (const auto& e : o.effects) c << " --effect " << e;
  c << " --out " << o.out_dir;
  if (o.gzip) c << " --gzip";
  if (o.signals_csv) c << " --signals-csv";
  if (o.no_log) c << " --no-log";
  return c.str();
}

int RunSimulate(const SimulateOptions& o, CLI::App* cmd) {
  using namespace ndsid;
  config::SimulationConfig cfg =
      o.config_path.empty() ? config::SimulationConfig{} : config::LoadSimulationConfig(o.config_path);
  if (cmd->count("--seed")) cfg.seed = o.seed;
  if (cmd->count("--hours")) {
    cfg.duration.hours = o.hours;
    cfg.duration.drives = 0;
  }
  if (cmd->count("--drives")) cfg.duration.drives = o.drives;
  for (const auto& e : o.effects) config::ApplyEffect(cfg.effects, e);
  cfg.command_line = CommandLine(o, cmd);
  config::ValidateSimulationConfig(cfg);

  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(o.out_dir, ec);
  if (ec) throw ConfigError("--out " + o.out_dir + ": " + ec.message());
  const std::string log_name = o.gzip ? "drive.log.gz" : "drive.log";
  const std::string log_path = (fs::path(o.out_dir) / log_name).string();
  const std::string truth_path = (fs::path(o.out_dir) / "truth.yaml").string();
  const std::string csv_path = (fs::path(o.out_dir) / "signals.csv").string();

  std::optional<dbc::Database> db;
  std::unique_ptr<sim::CandumpLogWriter> log;
  if (!o.no_log) {
    db = dbc::ParseDbcFile(o.dbc_path);
    log = std::make_unique<sim::CandumpLogWriter>(*db, cfg, log_path);
  }
  std::unique_ptr<sim::SignalsCsvWriter> csv;
  if (o.signals_csv) csv = std::make_unique<sim::SignalsCsvWriter>(csv_path);

  const auto t0 = std::chrono::steady_clock::now();
  sim::TruthSummary summary;
  const auto drivers = sim::SimulateDrives(cfg, [&](sim::DriveResult&& d) {
    spdlog::debug("drive {}: {:.1f} km, {:.0f} s, driver {}", d.index, d.stats.distance_km, d.stats.duration_s, d.driver);
    if (log) log->WriteDrive(d);
    if (csv) csv->WriteDrive(d);
    summary.Add(d);
  });
  if (log) log->Close();
  if (csv) csv->Close();
  std::vector<std::pair<std::string, std::string>> files;
  if (log) files.emplace_back("candump_log", log_name);
  if (csv) files.emplace_back("signals_csv", "signals.csv");
  files.emplace_back("dbc", o.dbc_path);
  WriteFileAtomically(truth_path, sim::TruthYaml(cfg, drivers, summary, files));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const auto p = sim::BaseParams(cfg.vehicle);
  const double eg = model::SelfSteerGradient(p, cfg.vehicle.wheelbase_m);
  std::cout << "simulated " << summary.drives().size() << " drives, " << summary.hours() << " h, " << summary.km()
            << " km in " << seconds << " s (seed " << cfg.seed << ")\n";
  std::cout << "EG truth " << eg << " rad/(m/s^2) = " << model::EgToDegPerG(eg) << " deg/g\n";
  std::cout << "|a_y| moving: " << 100.0 * summary.FractionBelow(1.0) << " % < 1, " << 100.0 * summary.FractionBelow(2.0)
            << " % < 2, " << 100.0 * summary.FractionBelow(5.0) << " % < 5 m/s^2; gated " << 100.0 * summary.GatedFraction()
            << " %\n";
  std::cout << "effects:";
  bool any = false;
  for (const auto& e : config::EffectTable()) {
    const double v = cfg.effects.*e.field;
    const std::string name = e.name;
    if (name == "roll_frequency_hz" || name == "roll_damping_ratio") continue;
    if (v != 0.0) {
      std::cout << " " << e.name << "=" << v;
      any = true;
    }
  }
  if (!cfg.effects.mass_schedule_kg.empty()) std::cout << " mass_schedule_kg=[...]", any = true;
  std::cout << (any ? "" : " none") << "\n";
  if (log) std::cout << "wrote " << log_path << " (" << log->frames() << " frames)\n";
  if (csv) std::cout << "wrote " << csv_path << "\n";
  std::cout << "wrote " << truth_path << "\n";
  return 0;
}

void RegisterSimulate(CLI::App& parent, int& exit_code) {
  auto opts = std::make_shared<SimulateOptions>();
  auto* cmd = parent.add_subcommand("simulate", "Simulate naturalistic drives (candump log + truth) with hidden effects");
  cmd->add_option("--config", opts->config_path, "Simulation YAML (default: built-in = config/sim_cmax.yaml)");
  cmd->add_option("--dbc", opts->dbc_path, "DBC to encode the bus with")->capture_default_str();
  cmd->add_option("--seed", opts->seed, "Random seed (overrides the config)");
  auto* hours = cmd->add_option("--hours", opts->hours, "Drive until this many hours of driving");
  auto* drives = cmd->add_option("--drives", opts->drives, "Exactly this many drives (key cycles)");
  hours->excludes(drives);
  cmd->add_option("--effect", opts->effects, EffectHelp())->take_all()->allow_extra_args(false);
  cmd->add_option("--out", opts->out_dir, "Output directory (drive.log[.gz], truth.yaml, signals.csv)")->required();
  cmd->add_flag("--gzip", opts->gzip, "Write drive.log.gz (zlib) instead of drive.log");
  cmd->add_flag("--signals-csv", opts->signals_csv, "Also write signals.csv: true and measured signals at 100 Hz");
  cmd->add_flag("--no-log", opts->no_log, "Skip the CAN log (truth and CSV only)");
  cmd->callback([opts, cmd, &exit_code] { exit_code = RunSimulate(*opts, cmd); });
}

}  // namespace

NDSID_REGISTER_COMMAND(simulate, RegisterSimulate);
