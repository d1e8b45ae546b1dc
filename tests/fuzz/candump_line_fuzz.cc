// Fuzz target: one candump log line (ParseCandumpLine). A parsed frame must survive the round
// trip through FormatCandumpLine unchanged (the writer and the parser agree).
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "ndsid/can/candump_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string line(reinterpret_cast<const char*>(data), size);
  ndsid::can::CanFrame frame;
  std::string_view bus;
  if (!ndsid::can::ParseCandumpLine(line, frame, bus).empty()) return 0;
  const std::string again = ndsid::can::FormatCandumpLine(frame, bus);
  ndsid::can::CanFrame frame2;
  std::string_view bus2;
  if (!ndsid::can::ParseCandumpLine(again, frame2, bus2).empty()) std::abort();
  if (bus2 != bus || frame2.timestamp_ns != frame.timestamp_ns || frame2.id != frame.id ||
      frame2.len != frame.len || frame2.flags != frame.flags ||
      std::memcmp(frame2.data.data(), frame.data.data(), frame.len) != 0) {
    std::abort();
  }
  return 0;
}
