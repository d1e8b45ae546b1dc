// The dbc stage's named spdlog logger ("dbc"), created on first use. Private to the stage.
#pragma once

#include <spdlog/spdlog.h>

#include <memory>

namespace ndsid::dbc::internal {

std::shared_ptr<spdlog::logger> Logger();

}  // namespace ndsid::dbc::internal
