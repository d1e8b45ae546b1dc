// Frame -> physical signal values. The extraction plan for every selected signal is compiled
// once; Decode() is noexcept and allocation-free.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "ndsid/can/can_frame.h"
#include "ndsid/dbc/database.h"

namespace ndsid::dbc {

struct SignalSelector {
  std::string message;  // message name
  std::string signal;   // signal name
};

struct DecodedValue {
  int signal_index = -1;  // index into Decoder::signals()
  double value = 0.0;     // physical value (raw * factor + offset, or the IEEE value)
};

enum class DecodeVerdict {
  kDecoded,      // >= 0 values written (a multiplexed message may yield only some signals)
  kUnknownId,    // no selected signal in a message with this id
  kTooShort,     // a selected signal needs more bytes than the frame has: the signals that fit
                 // are still written (cantools raises instead; we keep what is valid)
  kNotData,      // remote or error frame
};

class Decoder {
 public:
  struct SelectedSignal {
    const Message* message;
    const Signal* signal;
  };

  // Selects every signal of every message when `selection` is empty. Throws ConfigError naming
  // the message/signal when a selector does not exist in the database. `db` must outlive this.
  explicit Decoder(const Database& db, std::span<const SignalSelector> selection = {});
  ~Decoder();
  Decoder(Decoder&&) noexcept;
  Decoder& operator=(Decoder&&) noexcept;

  // Decodes the selected signals of `frame` into `out` (sized >= max_signals_per_message());
  // `count` receives how many were written. A multiplexed signal is written only when the
  // multiplexor's raw value equals its mux_value. Frames longer than the DBC length decode.
  DecodeVerdict Decode(const can::CanFrame& frame, std::span<DecodedValue> out,
                       size_t& count) const noexcept;

  const std::vector<SelectedSignal>& signals() const { return selected_; }
  int SignalIndex(std::string_view message, std::string_view signal) const;  // -1 if absent
  size_t max_signals_per_message() const { return max_per_message_; }
  // Bytes a frame needs for the signal at `signal_index` (its multiplexor aside).
  uint32_t RequiredBytes(int signal_index) const;

 private:
  struct Plan;  // defined in decoder.cc
  std::vector<SelectedSignal> selected_;
  std::vector<Plan> plans_;                        // one per selected signal
  std::unordered_map<uint64_t, std::vector<int>> by_key_;  // (extended<<32|id) -> plan indices
  size_t max_per_message_ = 0;
};

}  // namespace ndsid::dbc
