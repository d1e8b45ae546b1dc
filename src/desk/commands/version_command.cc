// `ndsid version`: the version, the commit it was built from, and the version of every library
// the estimator's numbers depend on (compile-time headers; zlib also at run time).
#include <CLI/Version.hpp>
#include <spdlog/version.h>
#include <zlib.h>

#include <Eigen/Core>
#include <iostream>
#include <nlohmann/json.hpp>

#include "command_registry.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/publish/lcm_publisher.h"

namespace {

void RegisterVersion(CLI::App& parent, int& exit_code) {
  auto* cmd = parent.add_subcommand("version", "Print the version and the libraries built against");
  cmd->callback([&exit_code] {
    std::cout << "ndsid " << NDSID_VERSION << " (commit " << NDSID_GIT_COMMIT << ")\n"
              << "  Ceres " << ndsid::identify::CeresVersion() << "\n"
              << "  Eigen " << EIGEN_WORLD_VERSION << "." << EIGEN_MAJOR_VERSION << "." << EIGEN_MINOR_VERSION << "\n"
              << "  LCM " << ndsid::publish::LcmVersion() << "\n"
              << "  yaml-cpp " << NDSID_YAML_CPP_VERSION << "\n"
              << "  spdlog " << SPDLOG_VER_MAJOR << "." << SPDLOG_VER_MINOR << "." << SPDLOG_VER_PATCH << "\n"
              << "  nlohmann_json " << NLOHMANN_JSON_VERSION_MAJOR << "." << NLOHMANN_JSON_VERSION_MINOR << "."
              << NLOHMANN_JSON_VERSION_PATCH << "\n"
              << "  CLI11 " << CLI11_VERSION << "\n"
              << "  zlib " << ZLIB_VERSION << " (run time " << zlibVersion() << ")\n";
    exit_code = 0;
  });
}

}  // namespace

NDSID_REGISTER_COMMAND(version, RegisterVersion);
