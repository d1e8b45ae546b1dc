#include "dbc_lexer.h"

#include <algorithm>
#include <cctype>
#include <iterator>

#include "ndsid/dbc/dbc_parser.h"

namespace ndsid::dbc::internal {
namespace {

bool IsIdentStart(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_'; }
bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsIdentChar(char c) { return IsIdentStart(c) || IsDigit(c); }

}  // namespace

Lexer::Lexer(std::string_view text, const std::string& file) : text_(text), file_(file) {
  // A UTF-8 byte-order mark is not part of the first statement.
  if (text_.substr(0, 3) == "\xEF\xBB\xBF") pos_ = line_start_ = 3;
  next_ = Scan();
}

Token Lexer::Next() {
  Token t = next_;
  next_ = Scan();
  return t;
}

Token Lexer::Scan() {
  // Skip white space (any control character counts, as in CRLF files or stray tabs).
  while (pos_ < text_.size()) {
    const char c = text_[pos_];
    if (c == '\n') {
      ++line_;
      line_start_ = ++pos_;
    } else if (static_cast<unsigned char>(c) <= ' ') {
      ++pos_;
    } else {
      break;
    }
  }
  Token t;
  t.line = line_;
  t.column = static_cast<int>(pos_ - line_start_) + 1;
  t.first_on_line = t.line != last_token_line_;
  if (pos_ >= text_.size()) {
    t.kind = TokenKind::kEnd;
    return t;
  }
  const size_t begin = pos_;
  const char c = text_[pos_];
  const auto next_is_digit = [&](size_t at) {
    return at < text_.size() && (IsDigit(text_[at]) || (text_[at] == '.' && at + 1 < text_.size() && IsDigit(text_[at + 1])));
  };

  if (c == '"') {
    ++pos_;
    while (pos_ < text_.size() && text_[pos_] != '"') {
      if (text_[pos_] == '\\' && pos_ + 1 < text_.size()) {
        if (text_[pos_ + 1] == '\n') {
          ++line_;
          line_start_ = pos_ + 2;
        }
        pos_ += 2;
        continue;
      }
      if (text_[pos_] == '\n') {
        ++line_;
        line_start_ = pos_ + 1;
      }
      ++pos_;
    }
    if (pos_ >= text_.size()) throw DbcError(file_, t.line, t.column, "unterminated string");
    t.kind = TokenKind::kString;
    t.text = text_.substr(begin + 1, pos_ - begin - 1);
    ++pos_;
  } else if (IsIdentStart(c)) {
    while (pos_ < text_.size() && IsIdentChar(text_[pos_])) ++pos_;
    t.kind = TokenKind::kIdentifier;
    t.text = text_.substr(begin, pos_ - begin);
  } else if (IsDigit(c) || ((c == '-' || c == '+' || c == '.') && next_is_digit(pos_ + (c == '.' ? 0 : 1)))) {
    if (c == '-' || c == '+') ++pos_;
    if (text_.substr(pos_, 2) == "0x" || text_.substr(pos_, 2) == "0X") {
      pos_ += 2;
      while (pos_ < text_.size() && std::isxdigit(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    } else {
      while (pos_ < text_.size() && (IsDigit(text_[pos_]) || text_[pos_] == '.')) ++pos_;
      if (pos_ < text_.size() && (text_[pos_] == 'e' || text_[pos_] == 'E')) {
        size_t p = pos_ + 1;
        if (p < text_.size() && (text_[p] == '+' || text_[p] == '-')) ++p;
        if (p < text_.size() && IsDigit(text_[p])) {
          pos_ = p;
          while (pos_ < text_.size() && IsDigit(text_[pos_])) ++pos_;
        }
      }
    }
    t.kind = TokenKind::kNumber;
    t.text = text_.substr(begin, pos_ - begin);
  } else if (std::string_view(":;,|@()[]+-").find(c) != std::string_view::npos) {
    ++pos_;
    t.kind = TokenKind::kPunct;
    t.text = text_.substr(begin, 1);
  } else {
    throw DbcError(file_, t.line, t.column, std::string("unexpected character '") + c + "'");
  }
  last_token_line_ = t.line;
  return t;
}

std::string Unescape(std::string_view raw) {
  std::string out;
  out.reserve(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) {
    if (raw[i] == '\\' && i + 1 < raw.size() && (raw[i + 1] == '"' || raw[i + 1] == '\\')) ++i;
    out += raw[i];
  }
  return out;
}

bool IsKeyword(std::string_view word) {
  static constexpr std::string_view kKeywords[] = {
      "VERSION",      "NS_",           "NS_DESC_",         "CM_",        "BA_DEF_",         "BA_",
      "VAL_",         "CAT_DEF_",      "CAT_",             "FILTER",     "BA_DEF_DEF_",     "EV_DATA_",
      "ENVVAR_DATA_", "SGTYPE_",       "SGTYPE_VAL_",      "BA_DEF_SGTYPE_", "BA_SGTYPE_", "SIG_TYPE_REF_",
      "VAL_TABLE_",   "SIG_GROUP_",    "SIG_VALTYPE_",     "SIGTYPE_VALTYPE_", "BO_TX_BU_", "BA_DEF_REL_",
      "BA_REL_",      "BA_DEF_DEF_REL_", "BU_SG_REL_",     "BU_EV_REL_", "BU_BO_REL_",      "SG_MUL_VAL_",
      "BS_",          "BU_",           "BO_",              "SG_",        "EV_"};
  return std::find(std::begin(kKeywords), std::end(kKeywords), word) != std::end(kKeywords);
}

}  // namespace ndsid::dbc::internal
