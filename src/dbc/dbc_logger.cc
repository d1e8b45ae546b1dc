#include "dbc_logger.h"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <mutex>

namespace ndsid::dbc::internal {

std::shared_ptr<spdlog::logger> Logger() {
  static std::mutex mutex;
  std::lock_guard lock(mutex);
  if (auto existing = spdlog::get("dbc")) return existing;
  // Inherit the default logger's sinks, so the CLI's and the daemon's set-up applies to us.
  auto base = spdlog::default_logger();
  auto logger = std::make_shared<spdlog::logger>("dbc", base->sinks().begin(), base->sinks().end());
  logger->set_level(spdlog::get_level());
  spdlog::register_logger(logger);
  return logger;
}

}  // namespace ndsid::dbc::internal
