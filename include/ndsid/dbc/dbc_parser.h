// Parser for the DBC subset real files use (BO_, SG_ incl. multiplexing, VAL_, CM_, BA_DEF_,
// BA_, SIG_VALTYPE_, ...). Unknown sections are skipped; tolerated quirks become Warnings.
#pragma once

#include <string>
#include <string_view>

#include "ndsid/common/error.h"
#include "ndsid/dbc/database.h"

namespace ndsid::dbc {

// A DBC that cannot be loaded. what() is "file:line:column: message".
class DbcError : public ConfigError {
 public:
  DbcError(std::string file, int line, int column, const std::string& message);
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  int column() const { return column_; }

 private:
  std::string file_;
  int line_;
  int column_;
};

Database ParseDbcFile(const std::string& path);
Database ParseDbcText(std::string_view text, const std::string& file_name_for_messages);

}  // namespace ndsid::dbc
