// Writes a large candump log of the messages of a DBC with random payloads, each message at
// its GenMsgCycleTime (100 ms when it has none), for the decode benchmark.
//   ndsid_bench_make_log DBC OUT.log FRAMES [SEED]
// Payloads are random bytes, except that a multiplexor gets one of the values its DBC defines
// and IEEE float signals a finite value in their [min, max], so every decoder sees decodable
// frames (cantools rejects unknown multiplexor values).
#include <cstdio>
#include <cstdlib>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "ndsid/can/candump_reader.h"
#include "ndsid/common/error.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/encoder.h"

namespace {

struct Schedule {
  const ndsid::dbc::Message* message;
  int64_t period_us;
  int64_t next_us;
  std::vector<uint64_t> mux_values;
};

int Run(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s DBC OUT.log FRAMES [SEED]\n", argv[0]);
    return 2;
  }
  const ndsid::dbc::Database db = ndsid::dbc::ParseDbcFile(argv[1]);
  const long long frames = std::atoll(argv[3]);
  std::mt19937_64 rng(argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 1);
  std::vector<Schedule> schedule;
  for (const auto& m : db.messages) {
    Schedule s{&m, static_cast<int64_t>(m.cycle_time_ms.value_or(100.0) * 1000.0), 0, {}};
    std::set<uint64_t> mux;
    for (const auto& sig : m.signals) {
      if (sig.mux_role == ndsid::dbc::MuxRole::kMultiplexed) mux.insert(sig.mux_value);
    }
    s.mux_values.assign(mux.begin(), mux.end());
    s.next_us = static_cast<int64_t>(rng() % static_cast<uint64_t>(s.period_us));
    schedule.push_back(std::move(s));
  }
  if (schedule.empty()) throw ndsid::Error(std::string(argv[1]) + ": no messages");
  std::FILE* out = std::fopen(argv[2], "w");
  if (out == nullptr) throw ndsid::Error(std::string(argv[2]) + ": cannot create");
  constexpr int64_t kStartUs = 1'700'000'000'000'000;
  for (long long i = 0; i < frames; ++i) {
    Schedule* due = &schedule[0];
    for (auto& s : schedule) due = s.next_us < due->next_us ? &s : due;
    const ndsid::dbc::Message& m = *due->message;
    ndsid::can::CanFrame f;
    f.timestamp_ns = (kStartUs + due->next_us) * 1000;
    f.id = m.id;
    f.flags = m.extended ? ndsid::can::kFlagExtended : 0;
    f.len = static_cast<uint8_t>(m.length);
    for (int b = 0; b < f.len; ++b) f.data[b] = static_cast<uint8_t>(rng());
    const std::span<uint8_t> payload(f.data.data(), f.len);
    for (const auto& sig : m.signals) {
      if (sig.mux_role == ndsid::dbc::MuxRole::kMultiplexor && !due->mux_values.empty()) {
        ndsid::dbc::EncodeRaw(sig, due->mux_values[rng() % due->mux_values.size()], payload);
      } else if (sig.is_float()) {
        std::uniform_real_distribution<double> value(sig.minimum, sig.maximum);
        ndsid::dbc::EncodeSignal(sig, value(rng), payload);
      }
    }
    due->next_us += due->period_us;
    std::fputs(ndsid::can::FormatCandumpLine(f, "can0").c_str(), out);
    std::fputc('\n', out);
  }
  return std::fclose(out) == 0 ? 0 : 1;
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
