#include "ndsid/dbc/database.h"

namespace ndsid::dbc {

const Signal* Message::FindSignal(std::string_view signal_name) const {
  for (const auto& s : signals) {
    if (s.name == signal_name) return &s;
  }
  return nullptr;
}

const Signal* Message::Multiplexor() const {
  for (const auto& s : signals) {
    if (s.mux_role == MuxRole::kMultiplexor) return &s;
  }
  return nullptr;
}

const Message* Database::FindMessage(uint32_t id, bool extended) const {
  for (const auto& m : messages) {
    if (m.id == id && m.extended == extended) return &m;
  }
  return nullptr;
}

const Message* Database::FindMessage(std::string_view name) const {
  for (const auto& m : messages) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

}  // namespace ndsid::dbc
