// ASAM MF4 bus-logging reader: the input as a whole file (the seeds are asammdf files).
#include "log_fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ndsid::fuzz::ReadLogFromBytes(data, size, "");
  return 0;
}
