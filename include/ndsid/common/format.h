// printf-style formatting into a std::string, sized to the result (no truncation): the checks'
// messages and the console summaries share it.
#pragma once

#include <string>

namespace ndsid {

std::string Fmt(const char* format, ...) __attribute__((format(printf, 1, 2)));

}  // namespace ndsid
