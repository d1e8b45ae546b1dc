// `ndsid init --dbc F --log L [--out vehicle.yaml]`: a new car's vehicle YAML from its DBC and a
// recorded log. The analysis is in vehicle_init.h; this file only reads, writes and prints.
// Exit status: 0 when the required roles (steering, speed, a_y) were found, 2 when not (the YAML
// is still written, with those roles commented out), 78 for bad input.
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

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
  double wheelbase_m = 2.7;
  uint64_t max_frames = 20'000'000;
};

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

int Run(const InitArgs& a) {
  namespace fs = std::filesystem;
  const dbc::Database db = dbc::ParseDbcFile(a.dbc);
  const std::unique_ptr<can::FrameLog> log = can::OpenFrameLog(a.log);
  InitOptions options;
  options.bus = a.bus;
  options.reference_wheelbase_m = a.wheelbase_m;
  options.max_frames = a.max_frames;
  const InitResult result = ProposeVehicleConfig(db, *log, options);
  if (!log->io_error().empty()) std::cerr << "ndsid init: " << a.log << ": not read to its end: " << log->io_error() << "\n";

  const fs::path out_dir = fs::path(a.out).parent_path();
  InitYamlInputs in;
  in.vehicle_name = a.name.empty() ? fs::path(a.dbc).stem().string() : a.name;
  in.log_path = RelativeTo(a.log, out_dir);
  in.dbc_path = RelativeTo(a.dbc, out_dir);
  std::ostringstream cmd;
  cmd << "ndsid init --dbc " << a.dbc << " --log " << a.log << " --out " << a.out;
  if (!a.bus.empty()) cmd << " --bus " << a.bus;
  in.command_line = cmd.str();
  WriteFileAtomically(a.out, VehicleConfigYaml(result, in));
  std::cout << InitSummary(result) << "wrote " << a.out << "\n";
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
  cmd->add_option("--name", args->name, "vehicle.name (default: the DBC file's name)");
  cmd->add_option("--wheelbase", args->wheelbase_m, "wheelbase [m] for the steer-ratio plausibility (10..25)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 8.0));
  cmd->add_option("--max-frames", args->max_frames, "read at most this many frames (the decoded log is held in memory, ~1 GB per 20 M frames)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->callback([args, &exit_code] { exit_code = Run(*args); });
}

}  // namespace
}  // namespace ndsid::desk

NDSID_REGISTER_COMMAND(init, ndsid::desk::RegisterInit);
