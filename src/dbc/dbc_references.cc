#include "dbc_references.h"

#include "ndsid/dbc/dbc_parser.h"

namespace ndsid::dbc::internal {
namespace {

constexpr const char* kCycleTimeAttribute = "GenMsgCycleTime";

class Resolver {
 public:
  Resolver(Database& db, const std::unordered_map<uint32_t, size_t>& by_raw_id) : db_(db), by_raw_id_(by_raw_id) {}

  // Finds the message (and signal) a reference names, warning with `what` when absent.
  std::pair<Message*, Signal*> Lookup(const Reference& r, const char* what) {
    const auto it = by_raw_id_.find(r.raw_id);
    if (it == by_raw_id_.end()) {
      Warn(r.at, std::string(what) + " for unknown message " + std::to_string(r.raw_id) + ": ignored");
      return {nullptr, nullptr};
    }
    Message& m = db_.messages[it->second];
    if (r.signal.empty()) return {&m, nullptr};
    auto [index, fresh] = by_name_.try_emplace(&m);
    if (fresh) {  // built once per message: lookups stay O(1) however many signals it has
      for (auto& s : m.signals) index->second.emplace(s.name, &s);  // the first of a duplicated name
    }
    if (const auto s = index->second.find(r.signal); s != index->second.end()) return {&m, s->second};
    Warn(r.at, std::string(what) + " for signal " + r.signal + ", which message " + m.name + " does not have: ignored");
    return {nullptr, nullptr};
  }

 private:
  void Warn(const Token& t, std::string text) { db_.warnings.push_back({db_.file, t.line, t.column, std::move(text)}); }

  Database& db_;
  const std::unordered_map<uint32_t, size_t>& by_raw_id_;
  std::unordered_map<const Message*, std::unordered_map<std::string_view, Signal*>> by_name_;
};

}  // namespace

void References::Resolve(Database& db, const std::unordered_map<uint32_t, size_t>& by_raw_id) {
  Resolver r(db, by_raw_id);
  for (auto& c : comments) {
    auto [m, s] = r.Lookup(c, "comment");
    if (s) {
      s->comment = std::move(c.text);
    } else if (m && c.signal.empty()) {
      m->comment = std::move(c.text);
    }
  }
  for (auto& v : values) {
    if (auto [m, s] = r.Lookup(v, "VAL_ value table"); s) s->value_table = std::move(v.table);
  }
  for (const auto& p : value_types) {
    auto [m, s] = r.Lookup(p, "SIG_VALTYPE_");
    if (!s || p.type == 0) continue;
    const uint32_t needed = p.type == 1 ? 32 : 64;
    if (s->length != needed) {
      throw DbcError(db.file, p.type_token.line, p.type_token.column,
                     "SIG_VALTYPE_ " + std::to_string(p.type) + " needs a " + std::to_string(needed) + "-bit signal, but " +
                         s->name + " has " + std::to_string(s->length) + " bits");
    }
    s->value_type = p.type == 1 ? ValueType::kFloat32 : ValueType::kFloat64;
  }
  // cantools' rule: only with a BA_DEF_ "GenMsgCycleTime"; the message's own BA_ value if it
  // has one, else the BA_DEF_DEF_ default; 0 means "no cycle time".
  if (attribute_definitions.count(kCycleTimeAttribute) == 0) return;
  std::unordered_map<const Message*, double> explicit_ms;
  for (const auto& c : cycle_times) {
    if (auto [m, s] = r.Lookup(c, kCycleTimeAttribute); m) explicit_ms[m] = c.value_ms;
  }
  for (auto& m : db.messages) {
    const auto it = explicit_ms.find(&m);
    const double ms = it != explicit_ms.end() ? it->second : cycle_time_default_ms;
    if (ms != 0) m.cycle_time_ms = ms;
  }
}

}  // namespace ndsid::dbc::internal
