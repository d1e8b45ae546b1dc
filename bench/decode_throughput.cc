// Parse + decode throughput of the CAN and DBC stages over a candump log (plain timed main,
// wall clock, best of N passes; the file is read from the page cache after the first pass).
//   ndsid_bench_decode_throughput DBC LOG [PASSES] [CHECK_FRAMES]
// Prints key=value lines: parse-only and parse+decode rates, and a checksum of the decoded
// physical values of the first CHECK_FRAMES frames, to compare with the Python reference.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "ndsid/can/candump_reader.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"

namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

int Run(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s DBC LOG [PASSES] [CHECK_FRAMES]\n", argv[0]);
    return 2;
  }
  const int passes = argc > 3 ? std::atoi(argv[3]) : 3;
  const uint64_t check_frames = argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 0;
  const ndsid::dbc::Database db = ndsid::dbc::ParseDbcFile(argv[1]);
  const ndsid::dbc::Decoder decoder(db);  // every signal of every message
  std::vector<ndsid::can::CanFrame> frames(1024);
  std::vector<ndsid::dbc::DecodedValue> values(decoder.max_signals_per_message());

  double best_parse = 1e300;
  double best_decode = 1e300;
  uint64_t total = 0;
  uint64_t decoded_values = 0;
  uint64_t not_decoded = 0;
  double check_sum = 0.0;
  uint64_t check_values = 0;
  for (int pass = 0; pass < passes; ++pass) {
    {  // parse only
      ndsid::can::CandumpReader reader(argv[2]);
      const auto start = Clock::now();
      uint64_t n = 0;
      for (ndsid::can::ReadResult r; (r = reader.Read(frames, 0)).count > 0;) n += r.count;
      best_parse = std::min(best_parse, Seconds(start));
      total = n;
    }
    {  // parse + decode every signal
      ndsid::can::CandumpReader reader(argv[2]);
      const auto start = Clock::now();
      uint64_t n = 0;
      uint64_t count_values = 0;
      uint64_t misses = 0;
      double sum = 0.0;
      uint64_t sum_values = 0;
      for (ndsid::can::ReadResult r; (r = reader.Read(frames, 0)).count > 0;) {
        for (size_t i = 0; i < r.count; ++i, ++n) {
          size_t count = 0;
          if (decoder.Decode(frames[i], values, count) != ndsid::dbc::DecodeVerdict::kDecoded) {
            ++misses;
            continue;
          }
          count_values += count;
          if (n < check_frames) {
            for (size_t k = 0; k < count; ++k) sum += values[k].value;
            sum_values += count;
          }
        }
      }
      best_decode = std::min(best_decode, Seconds(start));
      decoded_values = count_values;
      not_decoded = misses;
      check_sum = sum;
      check_values = sum_values;
    }
  }
  std::printf("frames=%llu\n", static_cast<unsigned long long>(total));
  std::printf("signal_values=%llu\n", static_cast<unsigned long long>(decoded_values));
  std::printf("frames_not_decoded=%llu\n", static_cast<unsigned long long>(not_decoded));
  std::printf("parse_only_s=%.3f\nparse_only_fps=%.0f\n", best_parse, total / best_parse);
  std::printf("parse_decode_s=%.3f\nparse_decode_fps=%.0f\n", best_decode, total / best_decode);
  std::printf("check_frames=%llu\ncheck_values=%llu\ncheck_sum=%.6f\n",
              static_cast<unsigned long long>(std::min(check_frames, total)),
              static_cast<unsigned long long>(check_values), check_sum);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
