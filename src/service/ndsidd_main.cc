// ndsidd: the in-vehicle service (see docs/daemon.md). All logic is in daemon.h.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdlib>

#include "daemon.h"
#include "daemon_notify.h"
#include "ndsid/common/error.h"

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("ndsidd"));
  // journald (JOURNAL_STREAM set) timestamps every line itself.
  spdlog::set_pattern(std::getenv("JOURNAL_STREAM") ? "[%l] %v" : "[%Y-%m-%d %H:%M:%S.%e] [%^%l%$] %v");

  CLI::App app{"ndsidd: online identification of lateral vehicle dynamics (service)"};
  ndsid::service::DaemonOptions opt;
  bool check_only = false, show_state = false;
  app.add_option("--config", opt.config_path, "vehicle configuration (YAML)")->required();
  app.add_flag("--realtime", opt.realtime, "replay logs at recorded speed");
  app.add_option("--speed", opt.speed, "replay logs at this multiple of recorded speed (implies --realtime)");
  app.add_option("--persist-interval-s", opt.persist_interval_s, "write the learned state at least this often [s]")
      ->capture_default_str();
  app.add_flag("--check-config", check_only, "validate configuration and DBC, then exit (0, or 78 on an error)");
  app.add_flag("--show-state", show_state, "print the learned state of the configured vehicle, then exit");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);  // --help: 0; a bad command line is bad configuration
    return rc == 0 ? 0 : ndsid::kExitConfig;
  }

  try {
    if (check_only) return ndsid::service::CheckConfig(opt.config_path), 0;
    if (show_state) return ndsid::service::ShowState(opt.config_path);
    ndsid::service::Daemon daemon(opt, ndsid::service::SystemdNotifier());
    ndsid::service::InstallSignalHandlers(daemon);
    return daemon.Run();
  } catch (const ndsid::ConfigError& e) {
    spdlog::error("configuration: {}", e.what());
    return ndsid::kExitConfig;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
