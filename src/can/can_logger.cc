#include "can_logger.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace ndsid::can {

std::shared_ptr<spdlog::logger> CanLogger() {
  if (auto logger = spdlog::get("can")) return logger;
  try {
    return spdlog::stderr_color_mt("can");
  } catch (const spdlog::spdlog_ex&) {
    return spdlog::get("can");  // another thread registered it first
  }
}

}  // namespace ndsid::can
