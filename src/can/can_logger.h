// The CAN stage's one spdlog logger, named "can".
#pragma once

#include <memory>

#include <spdlog/logger.h>

namespace ndsid::can {

// Returns the logger "can", creating it (stderr, colour) on first use unless the application
// registered one with that name already.
std::shared_ptr<spdlog::logger> CanLogger();

}  // namespace ndsid::can
