#include "dbc_checks.h"

#include <bitset>
#include <string>
#include <vector>

#include "bit_layout.h"

namespace ndsid::dbc::internal {
namespace {

void Warn(Database& db, int line, std::string text) { db.warnings.push_back({db.file, line, 1, std::move(text)}); }

// Two signals can be in the same frame unless both are multiplexed by different values.
bool CanCoexist(const Signal& a, const Signal& b) {
  return !(a.mux_role == MuxRole::kMultiplexed && b.mux_role == MuxRole::kMultiplexed && a.mux_value != b.mux_value);
}

void CheckMultiplexing(Database& db, Message& m) {
  int multiplexors = 0;
  int multiplexed = 0;
  for (const auto& s : m.signals) {
    multiplexors += s.mux_role == MuxRole::kMultiplexor;
    multiplexed += s.mux_role == MuxRole::kMultiplexed;
  }
  if (multiplexors == 1 || (multiplexors == 0 && multiplexed == 0)) return;
  Warn(db, m.line,
       multiplexors > 1 ? "message " + m.name + " has " + std::to_string(multiplexors) +
                              " multiplexor signals ('M'); multiplexing ignored, all signals decoded"
                        : "message " + m.name + " has multiplexed signals ('mN') but no multiplexor ('M'); "
                                                "they are decoded as plain signals");
  for (auto& s : m.signals) {
    s.mux_role = MuxRole::kNone;
    s.mux_value = 0;
  }
}

}  // namespace

void CheckMessages(Database& db) {
  std::vector<std::bitset<kMaxPayloadBits>> bits;
  for (auto& m : db.messages) {
    CheckMultiplexing(db, m);
    bits.assign(m.signals.size(), {});
    for (size_t i = 0; i < m.signals.size(); ++i) {
      const Signal& s = m.signals[i];
      ForEachSignalBit(s, [&](uint32_t pos, uint32_t) { bits[i].set(pos); });
      const uint32_t needed = SignalRequiredBytes(s);
      if (needed > m.length) {
        Warn(db, s.line, "signal " + s.name + " needs " + std::to_string(needed) + " bytes but message " + m.name +
                             " is " + std::to_string(m.length) + " bytes long; it decodes only from longer frames");
      }
      for (size_t j = 0; j < i; ++j) {
        if (m.signals[j].name == s.name) {
          Warn(db, s.line, "message " + m.name + " defines signal " + s.name + " twice");
        } else if (CanCoexist(s, m.signals[j]) && (bits[i] & bits[j]).any()) {
          Warn(db, s.line, "signals " + m.signals[j].name + " and " + s.name + " of message " + m.name +
                               " overlap; both are decoded from the shared bits");
        }
      }
    }
  }
}

}  // namespace ndsid::dbc::internal
