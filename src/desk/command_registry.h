// Subcommands of the `ndsid` CLI register themselves (one file per command in commands/), so
// adding a command touches no shared file.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace ndsid::desk {

// Adds the subcommand to `parent`. The subcommand's callback stores its exit status in
// `exit_code` (0 success); errors of configuration or input are thrown as ndsid::ConfigError.
using CommandRegistrar = void (*)(CLI::App& parent, int& exit_code);

struct RegisteredCommand {
  std::string name;
  CommandRegistrar registrar;
};

int RegisterCommand(const char* name, CommandRegistrar registrar);
const std::vector<RegisteredCommand>& Commands();

}  // namespace ndsid::desk

#define NDSID_REGISTER_COMMAND(name, registrar) \
  [[maybe_unused]] static const int ndsid_registered_command_##name = ::ndsid::desk::RegisterCommand(#name, registrar)
