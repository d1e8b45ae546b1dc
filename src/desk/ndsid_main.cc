// ndsid: the engineer's command-line tool. Each subcommand lives in commands/<name>_command.cc.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>

#include "command_registry.h"
#include "ndsid/common/error.h"

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("ndsid"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%n] [%^%l%$] %v");

  CLI::App app{"ndsid: lateral vehicle dynamics from naturalistic driving"};
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, off")->capture_default_str();
  int exit_code = 0;
  for (const auto& cmd : ndsid::desk::Commands()) cmd.registrar(app, exit_code);
  app.parse_complete_callback([&] { spdlog::set_level(spdlog::level::from_str(log_level)); });

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);  // --help: 0; a bad command line is bad configuration, as in ndsidd
    return rc == 0 ? 0 : ndsid::kExitConfig;
  } catch (const ndsid::ConfigError& e) {
    spdlog::error("{}", e.what());
    return ndsid::kExitConfig;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return exit_code;
}
