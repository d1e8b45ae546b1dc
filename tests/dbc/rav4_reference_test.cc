// Real data end to end: the comma2k19 RAV4 candump log read with CandumpReader, bus can0
// decoded with the real Toyota DBC, compared with every row of the cantools reference decode
// (realdata/comma2k19-rav4-2017-segment/derived/*.decoded_reference.csv).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "ndsid/can/candump_reader.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"

namespace ndsid::dbc {
namespace {

const std::string kSegmentDir = NDSID_REALDATA_DIR "/comma2k19-rav4-2017-segment/derived";
const std::string kDbc = NDSID_REALDATA_DIR "/opendbc-dbc/toyota_new_mc_pt_generated.dbc";

// (time in µs, frame id, signal) -> value. The log's times have 6 decimals, as the CSV's.
using Key = std::tuple<int64_t, uint32_t, std::string>;

int64_t Microseconds(const std::string& seconds_text) {
  const auto dot = seconds_text.find('.');
  const std::string whole = seconds_text.substr(0, dot);
  std::string frac = dot == std::string::npos ? "" : seconds_text.substr(dot + 1);
  frac.resize(6, '0');
  return std::stoll(whole) * 1000000 + std::stoll(frac);
}

TEST(Rav4Reference, DecodesEveryReferenceRowOfTheRealSegmentLikeCantools) {
  const std::string log = kSegmentDir + "/rav4_2017_segment40.candump.log";
  const std::string csv = kSegmentDir + "/rav4_2017_segment40.decoded_reference.csv";
  for (const auto& path : {log, csv, kDbc}) {
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "skipped: real data " << path << " not found";
  }

  // The reference: every row, and the messages and signals it covers.
  std::map<Key, double> reference;
  std::set<std::pair<std::string, std::string>> covered;
  std::ifstream in(csv);
  std::string line;
  const auto next_line = [&] {
    if (!std::getline(in, line)) return false;
    if (!line.empty() && line.back() == '\r') line.pop_back();  // the CSV has CRLF line ends
    return true;
  };
  next_line();
  ASSERT_EQ(line, "t_s,frame_id,message,signal,value");
  while (next_line()) {
    std::stringstream row(line);
    std::string t, id, message, signal, value;
    std::getline(row, t, ',');
    std::getline(row, id, ',');
    std::getline(row, message, ',');
    std::getline(row, signal, ',');
    std::getline(row, value, ',');
    reference[{Microseconds(t), static_cast<uint32_t>(std::stoul(id, nullptr, 16)), signal}] = std::stod(value);
    covered.insert({message, signal});
  }
  ASSERT_GT(reference.size(), 70000u);

  const Database db = ParseDbcFile(kDbc);
  std::vector<SignalSelector> selection;
  for (const auto& [message, signal] : covered) selection.push_back({message, signal});
  const Decoder decoder(db, selection);

  can::CandumpReader reader(log);
  std::vector<can::CanFrame> frames(256);
  std::vector<DecodedValue> out(decoder.max_signals_per_message());
  size_t matched = 0;
  size_t decoded = 0;
  size_t mismatches = 0;
  for (;;) {
    const can::ReadResult r = reader.Read(frames, 0);
    for (size_t i = 0; i < r.count; ++i) {
      const can::CanFrame& f = frames[i];
      if (reader.bus_names().at(f.bus) != "can0") continue;
      size_t count = 0;
      if (decoder.Decode(f, out, count) == DecodeVerdict::kUnknownId) continue;
      for (size_t k = 0; k < count; ++k) {
        ++decoded;
        const auto& sel = decoder.signals()[static_cast<size_t>(out[k].signal_index)];
        // Timestamps are whole µs in the log; round the ns to µs.
        const Key key{(f.timestamp_ns + 500) / 1000, f.id, sel.signal->name};
        const auto it = reference.find(key);
        if (it == reference.end()) {
          ADD_FAILURE() << "not in the reference: t=" << std::get<0>(key) << " id=" << f.id << " " << sel.signal->name;
          if (++mismatches > 20) return;
          continue;
        }
        ++matched;
        // The CSV has %.10g: compare to 1e-9 relative.
        if (std::abs(out[k].value - it->second) > 1e-9 * std::max(1.0, std::abs(it->second))) {
          ADD_FAILURE() << sel.message->name << "." << sel.signal->name << " at " << std::get<0>(key) << " us: ours "
                        << out[k].value << " cantools " << it->second;
          if (++mismatches > 20) return;
        }
      }
    }
    if (r.state == can::SourceState::kEnd) break;
  }
  EXPECT_EQ(reader.counters().malformed, 0u);
  EXPECT_EQ(decoded, reference.size()) << "every decoded value is a reference row and vice versa";
  EXPECT_EQ(matched, reference.size());
  std::printf("RAV4 reference: %zu rows, %zu matched, %zu mismatches\n", reference.size(), matched, mismatches);
}

}  // namespace
}  // namespace ndsid::dbc
