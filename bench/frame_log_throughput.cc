// Read throughput of the log readers (plain timed main, wall clock, best of N passes; files
// from the page cache after the first pass):
//   ndsid_bench_frame_log_throughput PASSES LOG...
// Prints one line per file: format, frames, best time, frames/s, and a checksum of ids and
// payload bytes so the formats can be seen to deliver the same frames.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <vector>

#include "ndsid/can/frame_log.h"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s PASSES LOG...\n", argv[0]);
    return 2;
  }
  const int passes = std::atoi(argv[1]);
  std::vector<ndsid::can::CanFrame> frames(1024);
  try {
    for (int a = 2; a < argc; ++a) {
      double best = 1e300;
      uint64_t n = 0, sum = 0;
      std::string format;
      for (int pass = 0; pass < passes; ++pass) {
        const auto start = std::chrono::steady_clock::now();
        auto log = ndsid::can::OpenFrameLog(argv[a]);
        n = 0;
        sum = 0;
        for (ndsid::can::ReadResult r; (r = log->Read(frames, 0)).count > 0;) {
          n += r.count;
          for (size_t i = 0; i < r.count; ++i) {
            sum += frames[i].id;
            for (int k = 0; k < frames[i].len; ++k) sum += frames[i].data[static_cast<size_t>(k)];
          }
        }
        best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        format = ndsid::can::LogFormatName(log->format());
        if (!log->io_error().empty()) std::fprintf(stderr, "%s: %s\n", argv[a], log->io_error().c_str());
      }
      std::printf("%-12s %-40s frames=%llu best=%.3f s rate=%.2f M frames/s checksum=%llu\n", format.c_str(), argv[a],
                  static_cast<unsigned long long>(n), best, n / best / 1e6, static_cast<unsigned long long>(sum));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
