// Vector BLF reader: the input as a whole file (the seeds start with "LOGG"; mutations that
// break the magic exercise the format sniffer instead).
#include "log_fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ndsid::fuzz::ReadLogFromBytes(data, size, "");
  return 0;
}
