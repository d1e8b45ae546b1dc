// The fuzz input as a file (the log readers take paths): a memfd, named /proc/self/fd/N, read
// through can::OpenFrameLog like any log, every frame pulled. Set-up errors (ndsid::Error,
// e.g. an unsupported format) are fine; crashes, sanitizer reports and hangs are not.
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "ndsid/can/frame_log.h"
#include "ndsid/common/error.h"

namespace ndsid::fuzz {

// `prefix` is written before the input, so the sniffer sends the mutated bytes to one reader.
inline void ReadLogFromBytes(const uint8_t* data, size_t size, const std::string& prefix) {
  static const int fd = memfd_create("ndsid_log_fuzz", 0);
  if (fd < 0) return;
  if (ftruncate(fd, 0) != 0 || lseek(fd, 0, SEEK_SET) != 0) return;
  if (!prefix.empty() && write(fd, prefix.data(), prefix.size()) != static_cast<ssize_t>(prefix.size())) return;
  if (size > 0 && write(fd, data, size) != static_cast<ssize_t>(size)) return;
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  try {
    auto log = can::OpenFrameLog(path);
    std::vector<can::CanFrame> frames(64);
    uint64_t total = 0;
    for (;;) {
      const auto r = log->Read(frames, 0);
      for (size_t i = 0; i < r.count; ++i) {
        const auto& f = frames[i];
        if (f.len > can::kMaxPayload || f.bus >= log->bus_names().size()) __builtin_trap();
        total += f.len;
      }
      if (r.state == can::SourceState::kEnd) break;
    }
    for (const auto& m : log->first_malformed()) total += log->Locate(m).size();
    (void)total;
  } catch (const ndsid::Error&) {
  }
}

}  // namespace ndsid::fuzz
