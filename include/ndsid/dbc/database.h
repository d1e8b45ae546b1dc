// In-memory model of a DBC file: messages, signals and their attributes.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ndsid::dbc {

enum class ByteOrder { kLittleEndian, kBigEndian };  // DBC "@1" (Intel) / "@0" (Motorola)
enum class ValueType { kUnsigned, kSigned, kFloat32, kFloat64 };  // "+", "-", SIG_VALTYPE_ 1/2
enum class MuxRole { kNone, kMultiplexor, kMultiplexed };         // "", "M", "mN"

struct Signal {
  std::string name;
  uint32_t start_bit = 0;  // as written in the DBC (Motorola: MSB position in DBC numbering)
  uint32_t length = 0;     // bits, 1..64
  ByteOrder byte_order = ByteOrder::kLittleEndian;
  ValueType value_type = ValueType::kUnsigned;
  double factor = 1.0;  // physical = raw * factor + offset
  double offset = 0.0;
  double minimum = 0.0;
  double maximum = 0.0;
  std::string unit;
  std::vector<std::string> receivers;
  MuxRole mux_role = MuxRole::kNone;
  uint64_t mux_value = 0;                      // for kMultiplexed: the multiplexor value selecting it
  std::map<int64_t, std::string> value_table;  // VAL_
  std::string comment;                         // CM_ SG_
  int line = 0;                                // line of the SG_ in the file

  bool is_float() const { return value_type == ValueType::kFloat32 || value_type == ValueType::kFloat64; }
  bool is_signed() const { return value_type == ValueType::kSigned; }
};

struct Message {
  uint32_t id = 0;        // 11- or 29-bit identifier, without the DBC's bit-31 extended flag
  bool extended = false;  // BO_ id had bit 31 set
  std::string name;
  uint32_t length = 0;  // bytes (DLC as declared)
  std::string sender;
  std::vector<Signal> signals;
  std::string comment;                   // CM_ BO_
  std::optional<double> cycle_time_ms;   // BA_ "GenMsgCycleTime" (cantools rule, see docs/dbc.md)
  int line = 0;

  // The multiplexor signal (MuxRole::kMultiplexor), or nullptr for a plain message.
  const Signal* Multiplexor() const;

  const Signal* FindSignal(std::string_view signal_name) const;
};

// A problem the parser tolerated (the file still loads): where, and what it did about it.
struct Warning {
  std::string file;
  int line = 0;
  int column = 0;
  std::string text;
};

struct Database {
  std::string file;  // path it was loaded from, for messages
  std::string version;
  std::string comment;  // global CM_ "..." (several are joined with a newline)
  std::vector<std::string> nodes;
  std::vector<Message> messages;
  std::vector<Warning> warnings;

  const Message* FindMessage(uint32_t id, bool extended) const;
  const Message* FindMessage(std::string_view name) const;
};

}  // namespace ndsid::dbc
