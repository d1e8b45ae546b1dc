// `ndsid decode`: a CAN log (any format of can::OpenFrameLog) decoded with a DBC, as CSV on stdout (like `cantools decode`,
// one row per signal value). Malformed lines, unknown ids and short frames are counted and
// summarised on stderr at the end.
#include <cinttypes>
#include <cstdio>
#include <iostream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "command_registry.h"
#include "ndsid/can/frame_log.h"
#include "ndsid/common/error.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"

namespace ndsid::desk {
namespace {

struct DecodeArgs {
  std::string dbc;
  std::string log;
  std::vector<std::string> messages;
  std::vector<std::string> signals;
  std::string bus;  // empty: every bus
};

// The signals of the named messages (all messages if none named), restricted to the named
// signals if any. Names that select nothing are configuration errors.
std::vector<dbc::SignalSelector> Select(const dbc::Database& db, const DecodeArgs& a) {
  const std::set<std::string> messages(a.messages.begin(), a.messages.end());
  const std::set<std::string> signals(a.signals.begin(), a.signals.end());
  for (const auto& m : messages) {
    if (db.FindMessage(m) == nullptr) throw ConfigError("--messages: " + a.dbc + " has no message " + m);
  }
  std::vector<dbc::SignalSelector> selection;
  std::set<std::string> found;
  for (const auto& m : db.messages) {
    if (!messages.empty() && messages.count(m.name) == 0) continue;
    for (const auto& s : m.signals) {
      if (!signals.empty() && signals.count(s.name) == 0) continue;
      selection.push_back({m.name, s.name});
      found.insert(s.name);
    }
  }
  for (const auto& s : signals) {
    if (found.count(s) == 0) throw ConfigError("--signals: no selected message of " + a.dbc + " has a signal " + s);
  }
  if (selection.empty()) throw ConfigError("nothing to decode: the selection has no signals");
  return selection;
}

// "sec.usec" from nanoseconds, exact (no floating point), as candump writes it.
void PrintTime(int64_t ns, char* buf, size_t size) {
  const int64_t us = (ns >= 0 ? ns + 500 : ns - 500) / 1000;
  const int64_t abs_us = us < 0 ? -us : us;
  std::snprintf(buf, size, "%s%" PRId64 ".%06" PRId64, us < 0 ? "-" : "", abs_us / 1000000, abs_us % 1000000);
}

int Run(const DecodeArgs& a) {
  const dbc::Database db = dbc::ParseDbcFile(a.dbc);
  const std::vector<dbc::SignalSelector> selection = Select(db, a);
  const dbc::Decoder decoder(db, selection);
  const std::unique_ptr<can::FrameLog> log = can::OpenFrameLog(a.log);
  can::FrameLog& reader = *log;

  struct Counts {
    uint64_t frames = 0, decoded = 0, values = 0, unknown_id = 0, too_short = 0, not_data = 0, other_bus = 0;
  } n;
  std::vector<can::CanFrame> frames(512);
  std::vector<dbc::DecodedValue> out(decoder.max_signals_per_message());
  std::printf("t,message,signal,value\n");
  char time_text[32];
  for (;;) {
    const can::ReadResult r = reader.Read(frames, 0);
    for (size_t i = 0; i < r.count; ++i) {
      const can::CanFrame& f = frames[i];
      ++n.frames;
      if (!a.bus.empty() && (f.bus >= reader.bus_names().size() || reader.bus_names()[f.bus] != a.bus)) {
        ++n.other_bus;
        continue;
      }
      size_t count = 0;
      switch (decoder.Decode(f, out, count)) {
        case dbc::DecodeVerdict::kDecoded: ++n.decoded; break;
        case dbc::DecodeVerdict::kTooShort: ++n.too_short; break;
        case dbc::DecodeVerdict::kUnknownId: ++n.unknown_id; break;
        case dbc::DecodeVerdict::kNotData: ++n.not_data; break;
      }
      if (count == 0) continue;
      PrintTime(f.timestamp_ns, time_text, sizeof time_text);
      for (size_t k = 0; k < count; ++k) {
        const auto& sel = decoder.signals()[static_cast<size_t>(out[k].signal_index)];
        std::printf("%s,%s,%s,%.10g\n", time_text, sel.message->name.c_str(), sel.signal->name.c_str(), out[k].value);
        ++n.values;
      }
    }
    if (r.state == can::SourceState::kEnd) break;
  }
  std::fflush(stdout);

  const auto& c = reader.counters();
  std::cerr << "ndsid decode: " << n.frames << " frames, " << n.decoded << " decoded, " << n.values << " values; "
            << n.unknown_id << " unknown id, " << n.too_short << " too short, " << n.not_data << " remote/error, "
            << n.other_bus << " on other buses, " << c.malformed << " malformed "
            << (reader.format() == can::LogFormat::kCandump || reader.format() == can::LogFormat::kAsc ? "lines" : "records")
            << " (" << can::LogFormatName(reader.format()) << ")\n";
  for (const auto& m : reader.first_malformed()) std::cerr << "  " << reader.Locate(m) << "\n";
  if (!reader.io_error().empty()) {  // truncated or unreadable: the CSV above is incomplete
    std::cerr << "ndsid decode: " << a.log << ": not read to its end: reading stopped after " << c.frames
              << " frames: " << reader.io_error() << "\n";
    return kExitIo;
  }
  return 0;
}

void RegisterDecode(CLI::App& parent, int& exit_code) {
  auto args = std::make_shared<DecodeArgs>();
  auto* cmd = parent.add_subcommand("decode", "Decode a CAN log (candump, ASC, BLF, MF4) with a DBC; CSV t,message,signal,value on stdout");
  cmd->add_option("--dbc", args->dbc, "DBC file")->required()->check(CLI::ExistingFile);
  cmd->add_option("--log", args->log, "CAN log: candump -l (plain or gzip), Vector ASC/BLF, ASAM MF4 bus logging")->required()->check(CLI::ExistingFile);
  cmd->add_option("--messages", args->messages, "only these messages (comma-separated names)")->delimiter(',');
  cmd->add_option("--signals", args->signals, "only these signals (comma-separated names)")->delimiter(',');
  cmd->add_option("--bus", args->bus, "only frames from this interface, e.g. can0 (default: all)");
  cmd->callback([args, &exit_code] { exit_code = Run(*args); });
}

}  // namespace
}  // namespace ndsid::desk

NDSID_REGISTER_COMMAND(decode, ndsid::desk::RegisterDecode);
