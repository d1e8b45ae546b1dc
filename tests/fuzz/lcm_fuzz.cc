// Fuzz target: estimate_t bytes through DecodeEstimate, the LCM decoding the tools and tests do
// in C++. Only ndsid::Error may come out. (status_t and monitor_t are decoded only by the Python
// tools; lcm-gen 1.3.1's C++ decode of them throws std::length_error on a string length of 0
// and allocates without limit on a huge array count: docs/reliability.md.)
#include <cstdint>
#include <string>

#include "ndsid/common/error.h"
#include "ndsid/publish/lcm_publisher.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    ndsid::publish::DecodeEstimate(bytes);
  } catch (const ndsid::Error&) {
  }
  return 0;
}
