#include "dbc_checks.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "bit_layout.h"

namespace ndsid::dbc::internal {
namespace {

void Warn(Database& db, int line, std::string text) { db.warnings.push_back({db.file, line, 1, std::move(text)}); }

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

// Overlaps in O(bits · log n) per message and bounded memory, however many signals it has
// (a message of 50 000 signals once took gigabytes as a pairwise check): each payload bit
// remembers its first owner among the plain signals, among the multiplexed ones and per mux
// value, so each signal is compared with at most a few earlier owners per bit. A signal is
// reported once, with the first earlier signal it shares bits with (the pair that can be in one
// frame); after kMaxOverlapWarnings signals in a message the rest are counted in one line.
void CheckMessages(Database& db) {
  constexpr size_t kMaxOverlapWarnings = 100;
  constexpr size_t kNone = SIZE_MAX;
  for (auto& m : db.messages) {
    CheckMultiplexing(db, m);
    std::vector<size_t> plain_owner(kMaxPayloadBits, kNone), muxed_owner(kMaxPayloadBits, kNone);
    std::vector<std::map<uint64_t, size_t>> owner_by_value(kMaxPayloadBits);
    std::unordered_map<std::string_view, size_t> by_name;
    size_t overlapping = 0;
    for (size_t i = 0; i < m.signals.size(); ++i) {
      const Signal& s = m.signals[i];
      const uint32_t needed = SignalRequiredBytes(s);
      if (needed > m.length) {
        Warn(db, s.line, "signal " + s.name + " needs " + std::to_string(needed) + " bytes but message " + m.name +
                             " is " + std::to_string(m.length) + " bytes long; it decodes only from longer frames");
      }
      const bool duplicate = !by_name.emplace(s.name, i).second;
      if (duplicate) Warn(db, s.line, "message " + m.name + " defines signal " + s.name + " twice");
      const bool multiplexed = s.mux_role == MuxRole::kMultiplexed;
      size_t first = kNone;
      ForEachSignalBit(s, [&](uint32_t pos, uint32_t) {
        first = std::min(first, plain_owner[pos]);  // a plain signal coexists with every other
        if (!multiplexed) {
          first = std::min(first, muxed_owner[pos]);
        } else if (const auto it = owner_by_value[pos].find(s.mux_value); it != owner_by_value[pos].end()) {
          first = std::min(first, it->second);
        }
        if (!multiplexed) {
          if (plain_owner[pos] == kNone) plain_owner[pos] = i;
        } else {
          if (muxed_owner[pos] == kNone) muxed_owner[pos] = i;
          owner_by_value[pos].emplace(s.mux_value, i);
        }
      });
      if (duplicate || first == kNone) continue;
      if (++overlapping <= kMaxOverlapWarnings) {
        Warn(db, s.line, "signals " + m.signals[first].name + " and " + s.name + " of message " + m.name +
                             " overlap; both are decoded from the shared bits");
      }
    }
    if (overlapping > kMaxOverlapWarnings) {
      Warn(db, m.line, "message " + m.name + ": " + std::to_string(overlapping - kMaxOverlapWarnings) +
                           " more signals overlap earlier ones (not listed)");
    }
  }
}

}  // namespace ndsid::dbc::internal
