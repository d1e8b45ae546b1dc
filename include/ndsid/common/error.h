// The project's one error type. Thrown at set-up only (configuration, DBC, sockets, files);
// the per-frame path is noexcept and counts rejections instead.
#pragma once

#include <stdexcept>
#include <string>

namespace ndsid {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Bad configuration or input definition (YAML, DBC, command line). Binaries exit with
// kExitConfig so systemd does not restart-loop on a configuration that can never work.
class ConfigError : public Error {
 public:
  using Error::Error;
};

inline constexpr int kExitConfig = 78;  // EX_CONFIG from sysexits.h
// Input that could not be read to its end (a truncated gzip log, a read error) or learned state
// that could not be saved at exit: the run's result is incomplete (docs/reliability.md).
inline constexpr int kExitIo = 74;      // EX_IOERR from sysexits.h

// "file:line:column: message" (line/column omitted when 0), the one format for locations.
std::string FormatLocation(const std::string& file, int line, int column, const std::string& message);

}  // namespace ndsid
