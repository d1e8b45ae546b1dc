// Vector ASC reader: arbitrary text after an ASC header line (so the sniffer picks ASC).
#include "log_fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ndsid::fuzz::ReadLogFromBytes(data, size, "base hex  timestamps absolute\n");
  return 0;
}
