// Extraction plans: a signal of up to 64 bits at any bit offset spans at most 9 bytes. The plan
// stores those bytes' range and the shift/mask that isolates the value once they are read into
// a 128-bit accumulator (big-endian order for Motorola, little-endian for Intel).
//
// Motorola (DBC @0): the start bit s names the most significant bit in the sawtooth numbering
// (bit s % 8 of byte s / 8). In MSB-first "network" numbering, where bit 0 is the top bit of
// byte 0, that bit is n = 8 * (s / 8) + 7 - s % 8, and the signal occupies n .. n + length - 1.
#include "ndsid/dbc/decoder.h"

#include <algorithm>
#include <bit>
#include <cstring>

#include "ndsid/common/error.h"

namespace ndsid::dbc {

namespace {

struct BitExtract {
  uint16_t first_byte = 0;
  uint8_t byte_count = 0;  // 1..9
  uint8_t shift = 0;       // right shift of the accumulator
  bool big_endian = false;
  uint64_t mask = 0;
  uint32_t needed_len = 0;  // bytes the frame must have

  uint64_t Read(const uint8_t* data) const noexcept {
    unsigned __int128 acc = 0;
    if (big_endian) {
      for (int i = 0; i < byte_count; ++i) acc = (acc << 8) | data[first_byte + i];
    } else {
      for (int i = byte_count - 1; i >= 0; --i) acc = (acc << 8) | data[first_byte + i];
    }
    return static_cast<uint64_t>(acc >> shift) & mask;
  }
};

BitExtract Compile(const Signal& s) {
  BitExtract e;
  e.mask = s.length >= 64 ? ~uint64_t{0} : (uint64_t{1} << s.length) - 1;
  uint32_t first = 0;
  uint32_t last = 0;
  if (s.byte_order == ByteOrder::kBigEndian) {
    const uint32_t msb = 8 * (s.start_bit / 8) + 7 - s.start_bit % 8;
    const uint32_t lsb = msb + s.length - 1;
    first = msb / 8;
    last = lsb / 8;
    e.shift = static_cast<uint8_t>(8 * (last + 1) - 1 - lsb);
    e.big_endian = true;
  } else {
    first = s.start_bit / 8;
    last = (s.start_bit + s.length - 1) / 8;
    e.shift = static_cast<uint8_t>(s.start_bit % 8);
  }
  e.first_byte = static_cast<uint16_t>(first);
  e.byte_count = static_cast<uint8_t>(last - first + 1);
  e.needed_len = last + 1;
  return e;
}

uint64_t Key(uint32_t id, bool extended) { return (uint64_t{extended} << 32) | id; }

}  // namespace

struct Decoder::Plan {
  BitExtract bits;
  ValueType type = ValueType::kUnsigned;
  uint32_t length = 0;
  double factor = 1.0;
  double offset = 0.0;
  bool multiplexed = false;
  BitExtract mux_bits;  // the message's multiplexor, when `multiplexed`
  uint64_t mux_value = 0;

  double Physical(const uint8_t* data) const noexcept {
    const uint64_t raw = bits.Read(data);
    switch (type) {
      case ValueType::kFloat32:
        return static_cast<double>(std::bit_cast<float>(static_cast<uint32_t>(raw))) * factor + offset;
      case ValueType::kFloat64:
        return std::bit_cast<double>(raw) * factor + offset;
      case ValueType::kSigned: {
        const uint64_t sign = uint64_t{1} << (length - 1);
        const int64_t value = static_cast<int64_t>((raw ^ sign) - sign);  // sign extension
        return static_cast<double>(value) * factor + offset;
      }
      case ValueType::kUnsigned:
        break;
    }
    return static_cast<double>(raw) * factor + offset;
  }
};

Decoder::Decoder(const Database& db, std::span<const SignalSelector> selection) {
  auto add = [this](const Message& m, const Signal& s) {
    for (const auto& sel : selected_) {
      if (sel.signal == &s) return;  // selected twice
    }
    Plan p;
    p.bits = Compile(s);
    p.type = s.value_type;
    p.length = s.length;
    p.factor = s.factor;
    p.offset = s.offset;
    const Signal* mux = m.Multiplexor();
    if (s.mux_role == MuxRole::kMultiplexed && mux != nullptr) {
      p.multiplexed = true;
      p.mux_bits = Compile(*mux);
      p.mux_value = s.mux_value;
    }
    by_key_[Key(m.id, m.extended)].push_back(static_cast<int>(plans_.size()));
    plans_.push_back(p);
    selected_.push_back({&m, &s});
  };

  if (selection.empty()) {
    for (const auto& m : db.messages) {
      for (const auto& s : m.signals) add(m, s);
    }
  }
  for (const auto& sel : selection) {
    const Message* m = db.FindMessage(sel.message);
    if (m == nullptr) throw ConfigError("DBC " + db.file + " has no message " + sel.message);
    const Signal* s = m->FindSignal(sel.signal);
    if (s == nullptr) throw ConfigError("DBC " + db.file + ": message " + sel.message + " has no signal " + sel.signal);
    add(*m, *s);
  }
  for (const auto& [key, indices] : by_key_) max_per_message_ = std::max(max_per_message_, indices.size());
}

Decoder::~Decoder() = default;
Decoder::Decoder(Decoder&&) noexcept = default;
Decoder& Decoder::operator=(Decoder&&) noexcept = default;

DecodeVerdict Decoder::Decode(const can::CanFrame& frame, std::span<DecodedValue> out, size_t& count) const noexcept {
  count = 0;
  if (frame.remote() || frame.error()) return DecodeVerdict::kNotData;
  const auto it = by_key_.find(Key(frame.id, frame.extended()));
  if (it == by_key_.end()) return DecodeVerdict::kUnknownId;
  const uint8_t* data = frame.data.data();
  const uint32_t len = std::min<uint32_t>(frame.len, can::kMaxPayload);
  bool too_short = false;
  for (const int index : it->second) {
    const Plan& p = plans_[static_cast<size_t>(index)];
    if (p.multiplexed) {
      if (len < p.mux_bits.needed_len) {
        too_short = true;
        continue;
      }
      if (p.mux_bits.Read(data) != p.mux_value) continue;
    }
    if (len < p.bits.needed_len) {
      too_short = true;
      continue;
    }
    if (count >= out.size()) break;
    out[count++] = {index, p.Physical(data)};
  }
  return too_short ? DecodeVerdict::kTooShort : DecodeVerdict::kDecoded;
}

int Decoder::SignalIndex(std::string_view message, std::string_view signal) const {
  for (size_t i = 0; i < selected_.size(); ++i) {
    if (selected_[i].message->name == message && selected_[i].signal->name == signal) return static_cast<int>(i);
  }
  return -1;
}

uint32_t Decoder::RequiredBytes(int signal_index) const { return plans_.at(static_cast<size_t>(signal_index)).bits.needed_len; }

}  // namespace ndsid::dbc
