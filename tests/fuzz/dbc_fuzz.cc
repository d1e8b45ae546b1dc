// Fuzz target: DBC text through ParseDbcText; a database that loads is compiled into a Decoder
// and frames built from the input's bytes are decoded for every message. Only DbcError (a
// located ConfigError) may come out of the parser.
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  ndsid::dbc::Database db;
  try {
    db = ndsid::dbc::ParseDbcText(text, "fuzz.dbc");
  } catch (const ndsid::dbc::DbcError&) {
    return 0;
  }
  const ndsid::dbc::Decoder decoder(db);
  std::vector<ndsid::dbc::DecodedValue> out(decoder.max_signals_per_message() + 1);
  for (const auto& m : db.messages) {
    for (int len : {0, static_cast<int>(m.length), 8, 64}) {
      ndsid::can::CanFrame f;
      f.id = m.id;
      f.flags = m.extended ? ndsid::can::kFlagExtended : 0;
      if (len > 8) f.flags |= ndsid::can::kFlagFd;
      f.len = static_cast<uint8_t>(len);
      for (int i = 0; i < len; ++i) f.data[i] = size > 0 ? data[(i * 7 + m.id) % size] : 0;
      size_t count = 0;
      decoder.Decode(f, out, count);
      if (count > decoder.max_signals_per_message()) __builtin_trap();
    }
  }
  return 0;
}
