// `ndsid version`: the version and the libraries it was built against.
#include <spdlog/version.h>

#include <iostream>

#include "command_registry.h"

namespace {

void RegisterVersion(CLI::App& parent, int& exit_code) {
  auto* cmd = parent.add_subcommand("version", "Print the version and the libraries built against");
  cmd->callback([&exit_code] {
    std::cout << "ndsid 0.1.0 (spdlog " << SPDLOG_VER_MAJOR << "."
              << SPDLOG_VER_MINOR << "." << SPDLOG_VER_PATCH << ")\n";
    exit_code = 0;
  });
}

}  // namespace

NDSID_REGISTER_COMMAND(version, RegisterVersion);
