// `ndsid init --dbc F --log L [--out vehicle.yaml]`: a new car's vehicle YAML from its DBC and a
// recorded log. The analysis is in vehicle_init.h; this file only reads, writes and prints.
// Exit status: 0 when the required roles (steering, speed, a_y) were found, 2 when not (the YAML
// is still written, with those roles commented out), 78 for bad input.
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <tuple>

#include <spdlog/fmt/fmt.h>

#include "command_registry.h"
#include "ndsid/can/frame_log.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/common/error.h"
#include "ndsid/dbc/dbc_parser.h"
#include "vehicle_init.h"

namespace ndsid::desk {
namespace {

constexpr int kExitRolesMissing = 2;

struct InitArgs {
  std::string dbc;
  std::string log;
  std::string out = "vehicle.yaml";
  std::string bus;
  std::string name;
  VehicleSheet vehicle;  // the data-sheet values given (NaN / 0: not given)
  uint64_t max_frames = 20'000'000;
};

// The axle loads both or neither, their sum near the mass (what the configuration checks when
// it loads); without --mass their sum is the mass.
void CheckVehicleSheet(VehicleSheet& v) {
  const bool front = v.front_axle_load_kg > 0, rear = v.rear_axle_load_kg > 0;
  if (front != rear) throw ConfigError("init: give both --front-axle-load-kg and --rear-axle-load-kg, or neither");
  if (!front) return;
  const double sum = v.front_axle_load_kg + v.rear_axle_load_kg;
  if (!std::isfinite(v.mass_kg)) {
    v.mass_kg = sum;
    std::cout << fmt::format("vehicle.mass_kg {:g}: the sum of the axle loads (no --mass)\n", sum);
  }
  if (std::fabs(sum - v.mass_kg) > 0.15 * v.mass_kg) {
    throw ConfigError(fmt::format("init: the axle loads add up to {:g} kg, more than 15 % from --mass {:g} kg", sum, v.mass_kg));
  }
}

// A file-name stem without the log's extensions: "drive.candump.log.gz" -> "drive".
std::string LogStem(const std::string& path) {
  std::string stem = std::filesystem::path(path).filename().string();
  static const char* kExtensions[] = {".gz", ".log", ".candump", ".asc", ".blf", ".mf4", ".mdf", ".trc", ".csv", ".txt"};
  for (bool again = true; again;) {
    again = false;
    for (const char* ext : kExtensions) {
      const std::string e = ext;
      if (stem.size() > e.size() && stem.compare(stem.size() - e.size(), e.size(), e) == 0) {
        stem.resize(stem.size() - e.size());
        again = true;
      }
    }
  }
  return stem;
}

// A name usable as a folder: letters, digits, '.', '-', '_'; anything else becomes '_'.
std::string FolderSafe(std::string name) {
  for (char& c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_')) c = '_';
  return name.empty() || name == "." || name == ".." ? "vehicle" : name;
}

// The vehicle names and state folders the other configs in `dir` use (their `name:` and
// `state_dir:` lines), so that a second car set up in the same folder gets its own.
std::set<std::string> NamesInFolder(const std::filesystem::path& dir, const std::filesystem::path& out) {
  namespace fs = std::filesystem;
  std::set<std::string> used;
  std::error_code ec;
  const std::regex line(R"re(^\s*(name|state_dir):\s*"?([^"#\s]+)"?)re");
  for (const auto& e : fs::directory_iterator(dir.empty() ? fs::path(".") : dir, ec)) {
    const std::string ext = e.path().extension().string();
    if (!e.is_regular_file(ec) || (ext != ".yaml" && ext != ".yml") || fs::equivalent(e.path(), out, ec)) continue;
    std::ifstream in(e.path());
    for (std::string text; std::getline(in, text);) {
      std::smatch m;
      if (!std::regex_search(text, m, line)) continue;
      const std::string value = m[2].str();
      used.insert(m[1].str() == "name" ? value : fs::path(value).filename().string());
    }
  }
  return used;
}

// vehicle.name: --name, else the log's stem and the DBC's ("drive-ndsid_example"); a default
// name another config of the folder already uses gets a suffix -2, -3, ...
std::pair<std::string, std::string> VehicleName(const InitArgs& a, std::string& note) {
  namespace fs = std::filesystem;
  const std::set<std::string> used = NamesInFolder(fs::path(a.out).parent_path(), fs::path(a.out));
  if (!a.name.empty()) {
    const std::string state = FolderSafe(a.name);
    if (used.count(a.name) || used.count(state))
      note = "WARNING: another config in this folder already uses the name '" + a.name + "': the two would share learned state";
    return {a.name, state};
  }
  const std::string base = FolderSafe(LogStem(a.log) + "-" + fs::path(a.dbc).stem().string());
  std::string name = base;
  for (int k = 2; used.count(name); ++k) name = base + "-" + std::to_string(k);
  if (name != base) note = "vehicle.name " + name + ": another config in this folder already uses " + base;
  return {name, name};
}

// `target` as written into a file in `dir`: relative when both are under a common root.
std::string RelativeTo(const std::string& target, const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path abs_target = fs::absolute(target, ec);
  const fs::path abs_dir = fs::absolute(dir.empty() ? fs::path(".") : dir, ec);
  const fs::path t = abs_target.lexically_normal(), d = abs_dir.lexically_normal();
  // Only when they share a top folder (a checkout), else absolute: /tmp/x -> /work/y is not portable.
  auto top = [](const fs::path& p) { auto it = p.begin(); return ++it == p.end() ? fs::path() : *it; };
  const fs::path rel = t.lexically_relative(d);
  return rel.empty() || top(t) != top(d) ? t.string() : rel.string();
}

int Run(InitArgs a) {
  namespace fs = std::filesystem;
  CheckVehicleSheet(a.vehicle);
  const dbc::Database db = dbc::ParseDbcFile(a.dbc);
  const std::unique_ptr<can::FrameLog> log = can::OpenFrameLog(a.log);
  InitOptions options;
  options.bus = a.bus;
  if (std::isfinite(a.vehicle.wheelbase_m)) options.reference_wheelbase_m = a.vehicle.wheelbase_m;
  options.max_frames = a.max_frames;
  const InitResult result = ProposeVehicleConfig(db, *log, options);
  if (!log->io_error().empty()) std::cerr << "ndsid init: " << a.log << ": not read to its end: " << log->io_error() << "\n";

  const fs::path out_dir = fs::path(a.out).parent_path();
  InitYamlInputs in;
  std::string name_note;
  std::tie(in.vehicle_name, in.state_name) = VehicleName(a, name_note);
  in.vehicle = a.vehicle;
  in.log_path = RelativeTo(a.log, out_dir);
  in.dbc_path = RelativeTo(a.dbc, out_dir);
  std::ostringstream cmd;
  cmd << "ndsid init --dbc " << a.dbc << " --log " << a.log << " --out " << a.out;
  if (!a.bus.empty()) cmd << " --bus " << a.bus;
  if (!a.name.empty()) cmd << " --name " << a.name;
  const VehicleSheet& v = a.vehicle;
  if (std::isfinite(v.wheelbase_m)) cmd << " --wheelbase " << v.wheelbase_m;
  if (std::isfinite(v.mass_kg)) cmd << " --mass " << v.mass_kg;
  if (v.front_axle_load_kg > 0)
    cmd << " --front-axle-load-kg " << v.front_axle_load_kg << " --rear-axle-load-kg " << v.rear_axle_load_kg;
  if (v.track_front_m > 0) cmd << " --track-front " << v.track_front_m;
  if (v.track_rear_m > 0) cmd << " --track-rear " << v.track_rear_m;
  in.command_line = cmd.str();
  WriteFileAtomically(a.out, VehicleConfigYaml(result, in));
  std::cout << InitSummary(result, a.vehicle);
  if (!name_note.empty()) std::cout << name_note << "\n";
  std::cout << "vehicle.name " << in.vehicle_name << ", learned state in out/state/" << in.state_name
            << " (relative to the config)\nwrote " << a.out << "\n";
  return result.MandatoryFound() ? 0 : kExitRolesMissing;
}

void RegisterInit(CLI::App& parent, int& exit_code) {
  auto args = std::make_shared<InitArgs>();
  auto* cmd = parent.add_subcommand(
      "init", "Set up a new car: propose the signal roles from a DBC, confirm them (signal, unit, sign) from a recorded log, write a commented vehicle YAML");
  cmd->add_option("--dbc", args->dbc, "the car's DBC file")->required()->check(CLI::ExistingFile);
  cmd->add_option("--log", args->log, "a recorded drive with some turning: candump -l (plain or gzip), Vector ASC/BLF, ASAM MF4")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", args->out, "vehicle YAML to write")->capture_default_str();
  cmd->add_option("--bus", args->bus, "only frames from this interface, e.g. can0 (default: each message on the bus it is seen most)");
  cmd->add_option("--name", args->name,
                  "vehicle.name, which keys the learned state (default: the log's and the DBC's file names, made unique "
                  "among the configs of the output folder)");
  cmd->add_option("--wheelbase", args->vehicle.wheelbase_m,
                  "wheelbase l [m] from the data sheet, written as vehicle.wheelbase_m (EG scales with it; without it "
                  "the key is written commented out and the file does not load until it is set)")
      ->check(CLI::Range(1.0, 8.0));
  cmd->add_option("--mass", args->vehicle.mass_kg, "mass m [kg] (curb + driver), written as vehicle.mass_kg (without it the key is written commented "
                  "out and the file does not load until it is set)")
      ->check(CLI::Range(200.0, 60000.0));
  cmd->add_option("--front-axle-load-kg", args->vehicle.front_axle_load_kg, "front axle load [kg] (with --rear-axle-load-kg)")
      ->check(CLI::Range(1.0, 60000.0));
  cmd->add_option("--rear-axle-load-kg", args->vehicle.rear_axle_load_kg, "rear axle load [kg] (with --front-axle-load-kg)")
      ->check(CLI::Range(1.0, 60000.0));
  cmd->add_option("--track-front", args->vehicle.track_front_m, "front track width [m]")->check(CLI::Range(0.3, 5.0));
  cmd->add_option("--track-rear", args->vehicle.track_rear_m, "rear track width [m]")->check(CLI::Range(0.3, 5.0));
  cmd->add_option("--max-frames", args->max_frames, "read at most this many frames (the decoded log is held in memory, ~1 GB per 20 M frames)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->callback([args, &exit_code] { exit_code = Run(*args); });
}

}  // namespace
}  // namespace ndsid::desk

NDSID_REGISTER_COMMAND(init, ndsid::desk::RegisterInit);
