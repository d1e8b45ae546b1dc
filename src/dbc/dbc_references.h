// Statements that name a message by its DBC id (CM_, VAL_, SIG_VALTYPE_, BA_ GenMsgCycleTime),
// collected while parsing and applied once every BO_ is known, so that sections may come in
// any order. Private to the dbc stage.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "dbc_lexer.h"
#include "ndsid/dbc/database.h"

namespace ndsid::dbc::internal {

struct Reference {
  uint32_t raw_id = 0;  // as in the file: bit 31 = extended
  std::string signal;   // empty: the message itself
  Token at;             // the statement keyword, for warnings
};
struct PendingComment : Reference {
  std::string text;
};
struct PendingValues : Reference {
  std::map<int64_t, std::string> table;
};
struct PendingValueType : Reference {
  int type = 0;  // 0 integer, 1 float32, 2 float64
  Token type_token;
};
struct PendingCycleTime : Reference {
  double value_ms = 0;
};

struct References {
  std::vector<PendingComment> comments;
  std::vector<PendingValues> values;
  std::vector<PendingValueType> value_types;
  std::vector<PendingCycleTime> cycle_times;
  std::set<std::string> attribute_definitions;  // BA_DEF_ names
  double cycle_time_default_ms = 0;             // BA_DEF_DEF_ "GenMsgCycleTime"

  // Applies everything to `db` (messages indexed by raw id in `by_raw_id`). Missing targets
  // become warnings; a float type on a signal of the wrong length throws DbcError.
  void Resolve(Database& db, const std::unordered_map<uint32_t, size_t>& by_raw_id);
};

}  // namespace ndsid::dbc::internal
