// Recursive-descent parser over the token stream of dbc_lexer. Statements are dispatched on
// their keyword; references between sections (CM_, VAL_, BA_, SIG_VALTYPE_ naming a message
// by id) are collected and resolved at the end, so sections may come in any order.
#include "ndsid/dbc/dbc_parser.h"

#include <cerrno>
#include <cmath>
#include <charconv>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <unordered_map>

#include "bit_layout.h"
#include "ndsid/common/atomic_file.h"
#include "dbc_checks.h"
#include "dbc_lexer.h"
#include "dbc_logger.h"
#include "dbc_references.h"

namespace ndsid::dbc {

DbcError::DbcError(std::string file, int line, int column, const std::string& message)
    : ConfigError(FormatLocation(file, line, column, message)), file_(std::move(file)), line_(line), column_(column) {}

namespace {

using internal::Token;
using internal::TokenKind;

constexpr uint32_t kExtendedFlag = 0x80000000u;
constexpr std::string_view kCycleTimeAttribute = "GenMsgCycleTime";
constexpr std::string_view kNoNode = "Vector__XXX";

std::string Describe(const Token& t) {
  if (t.kind == TokenKind::kEnd) return "end of file";
  if (t.kind == TokenKind::kString) return "a string";
  return "'" + std::string(t.text) + "'";
}

class Parser {
 public:
  Parser(std::string_view text, const std::string& file) : file_(file), lex_(text, file_) { db_.file = file; }

  Database Parse() {
    for (;;) {
      const Token t = lex_.Next();
      if (t.kind == TokenKind::kEnd) break;
      if (t.kind != TokenKind::kIdentifier) Fail(t, "expected a section keyword, got " + Describe(t));
      if (t.text == "SG_") {
        if (message_ == kNoMessage) Fail(t, "SG_ outside a BO_ message");
        ParseSignal(t);
        continue;
      }
      message_ = kNoMessage;
      if (t.text == "VERSION") {
        db_.version = internal::Unescape(Expect(TokenKind::kString, "a version string").text);
      } else if (t.text == "NS_") {
        SkipNewSymbols(t);
      } else if (t.text == "BU_") {
        ParseNodes();
      } else if (t.text == "BS_") {
        SkipStatement(t, false);
      } else if (t.text == "BO_") {
        ParseMessage(t);
      } else if (t.text == "CM_") {
        ParseComment(t);
      } else if (t.text == "BA_DEF_") {
        ParseAttributeDefinition(t);
      } else if (t.text == "BA_DEF_DEF_") {
        ParseAttributeDefault(t);
      } else if (t.text == "BA_") {
        ParseAttribute(t);
      } else if (t.text == "VAL_") {
        ParseValues(t);
      } else if (t.text == "SIG_VALTYPE_") {
        ParseValueType(t);
      } else if (t.text == "SG_MUL_VAL_") {
        Warn(t, "extended multiplexing (SG_MUL_VAL_) is not supported; the statement is ignored");
        SkipStatement(t, true);
      } else if (internal::IsKeyword(t.text)) {
        SkipStatement(t, true);  // VAL_TABLE_, BO_TX_BU_, EV_, ENVVAR_DATA_, SIG_GROUP_, ...: not needed
      } else {
        Warn(t, "unknown section '" + std::string(t.text) + "' skipped");
        SkipStatement(t, true);
      }
    }
    refs_.Resolve(db_, by_raw_id_);
    internal::CheckMessages(db_);
    return std::move(db_);
  }

 private:
  static constexpr int kNoMessage = -1;
  static constexpr int kDiscardedMessage = -2;  // SG_ lines belong to a message we do not keep

  [[noreturn]] void Fail(const Token& t, const std::string& message) { throw DbcError(file_, t.line, t.column, message); }
  void Warn(const Token& t, std::string text) { db_.warnings.push_back({file_, t.line, t.column, std::move(text)}); }

  Token Expect(TokenKind kind, const char* what) {
    Token t = lex_.Next();
    if (t.kind != kind) Fail(t, std::string("expected ") + what + ", got " + Describe(t));
    return t;
  }
  void ExpectPunct(char c) {
    const Token t = lex_.Next();
    if (!t.Is(c)) Fail(t, std::string("expected '") + c + "', got " + Describe(t));
  }
  bool AcceptPunct(char c) {
    if (!lex_.Peek().Is(c)) return false;
    lex_.Next();
    return true;
  }
  // The next token begins a new statement (a keyword first on its line) or the file ends.
  bool AtStatementStart() const {
    const Token& t = lex_.Peek();
    return t.kind == TokenKind::kEnd || (t.kind == TokenKind::kIdentifier && t.first_on_line && internal::IsKeyword(t.text));
  }

  double ParseDouble(const Token& t) {
    if (t.kind != TokenKind::kNumber) Fail(t, "expected a number, got " + Describe(t));
    std::string_view s = t.text;
    if (s.substr(0, 2) == "0x" || s.substr(0, 2) == "0X") return static_cast<double>(ParseUnsigned(t));
    if (!s.empty() && s[0] == '+') s.remove_prefix(1);
    double v = 0;
    const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
    if (r.ec != std::errc() || r.ptr != s.data() + s.size()) Fail(t, "malformed number '" + std::string(t.text) + "'");
    return v;
  }
  uint64_t ParseUnsigned(const Token& t) {
    if (t.kind != TokenKind::kNumber) Fail(t, "expected an unsigned integer, got " + Describe(t));
    std::string_view s = t.text;
    int base = 10;
    if (s.substr(0, 2) == "0x" || s.substr(0, 2) == "0X") {
      s.remove_prefix(2);
      base = 16;
    }
    uint64_t v = 0;
    const auto r = std::from_chars(s.data(), s.data() + s.size(), v, base);
    if (r.ec != std::errc() || r.ptr != s.data() + s.size()) Fail(t, "expected an unsigned integer, got " + Describe(t));
    return v;
  }
  // An integer: exact in the whole int64 range ("9223372036854775807"); a number written as a
  // float ("3.0", "1e3") must be integral and within int64 (no float-to-integer overflow).
  int64_t ParseInteger(const Token& t) {
    if (t.kind != TokenKind::kNumber) Fail(t, "expected an integer, got " + Describe(t));
    std::string_view s = t.text;
    if (!s.empty() && s[0] == '+') s.remove_prefix(1);
    int64_t i = 0;
    const auto r = std::from_chars(s.data(), s.data() + s.size(), i);
    if (r.ec == std::errc() && r.ptr == s.data() + s.size()) return i;
    const double v = ParseDouble(t);
    constexpr double kTwo63 = 9223372036854775808.0;  // 2^63, exactly representable
    if (!(v >= -kTwo63 && v < kTwo63) || v != std::trunc(v)) {
      Fail(t, "expected an integer within 64 bits, got " + Describe(t));
    }
    return static_cast<int64_t>(v);
  }
  uint32_t ParseMessageId(const Token& t) {
    const uint64_t id = ParseUnsigned(t);
    if (id > 0xFFFFFFFFu) Fail(t, "message id " + std::string(t.text) + " does not fit in 32 bits");
    return static_cast<uint32_t>(id);
  }

  // Ends a ';'-terminated statement. A missing ';' is tolerated when the next line starts a new
  // statement (seen in real files), else it is a syntax error.
  void EndStatement(const Token& keyword) {
    if (AcceptPunct(';')) return;
    if (AtStatementStart()) {
      Warn(keyword, std::string(keyword.text) + " statement without terminating ';' (ended at the next statement)");
      return;
    }
    Fail(lex_.Peek(), "expected ';', got " + Describe(lex_.Peek()));
  }
  void SkipStatement(const Token& keyword, bool semicolon_terminated) {
    while (!AtStatementStart()) {
      if (lex_.Next().Is(';')) return;
    }
    if (semicolon_terminated) {
      Warn(keyword, std::string(keyword.text) + " statement without terminating ';' (ended at the next statement)");
    }
  }

  // NS_ : followed by the names of optional sections, indented on the following lines.
  void SkipNewSymbols(const Token& ns) {
    AcceptPunct(':');
    while (lex_.Peek().kind == TokenKind::kIdentifier && (lex_.Peek().column > 1 || lex_.Peek().line == ns.line)) {
      lex_.Next();
    }
  }

  void ParseNodes() {
    AcceptPunct(':');
    while (!AtStatementStart() && lex_.Peek().kind == TokenKind::kIdentifier) {
      db_.nodes.emplace_back(lex_.Next().text);
    }
  }

  // BO_ id name: length sender
  void ParseMessage(const Token& bo) {
    const Token id_token = lex_.Next();
    const uint32_t raw_id = ParseMessageId(id_token);
    Message m;
    m.line = bo.line;
    m.extended = (raw_id & kExtendedFlag) != 0;
    m.id = raw_id & ~kExtendedFlag;
    m.name = std::string(Expect(TokenKind::kIdentifier, "a message name").text);
    ExpectPunct(':');
    const Token length_token = lex_.Next();
    const uint64_t length = ParseUnsigned(length_token);
    if (length > 64) Fail(length_token, "message length " + std::to_string(length) + " exceeds 64 bytes");
    m.length = static_cast<uint32_t>(length);
    if (lex_.Peek().kind == TokenKind::kIdentifier && !lex_.Peek().first_on_line) m.sender = std::string(lex_.Next().text);
    if (m.id > (m.extended ? 0x1FFFFFFFu : 0x7FFu)) {
      Warn(id_token, "message id " + std::to_string(m.id) + " is out of range for " +
                         (m.extended ? "a 29-bit" : "an 11-bit") + " identifier");
    }
    if (m.name == "VECTOR__INDEPENDENT_SIG_MSG") {  // holds unassigned signals; cantools drops it too
      message_ = kDiscardedMessage;
      return;
    }
    if (by_raw_id_.count(raw_id) != 0) {
      Warn(bo, "duplicate message id " + std::string(id_token.text) + " (" + m.name + "): this definition is ignored");
      message_ = kDiscardedMessage;
      return;
    }
    by_raw_id_[raw_id] = db_.messages.size();
    message_ = static_cast<int>(db_.messages.size());
    db_.messages.push_back(std::move(m));
  }

  // SG_ name [M|mN] : start|length@order sign (factor,offset) [min|max] "unit" receivers
  void ParseSignal(const Token& sg) {
    Signal s;
    s.line = sg.line;
    s.name = std::string(Expect(TokenKind::kIdentifier, "a signal name").text);
    if (lex_.Peek().kind == TokenKind::kIdentifier) ParseMuxIndicator(lex_.Next(), s);
    ExpectPunct(':');
    const Token start = lex_.Next();
    const uint64_t start_bit = ParseUnsigned(start);
    ExpectPunct('|');
    const Token length = lex_.Next();
    const uint64_t bits = ParseUnsigned(length);
    ExpectPunct('@');
    const Token order = lex_.Next();
    if (order.text == "1") {
      s.byte_order = ByteOrder::kLittleEndian;
    } else if (order.text == "0") {
      s.byte_order = ByteOrder::kBigEndian;
    } else {
      Fail(order, "byte order must be 0 (Motorola) or 1 (Intel), got " + Describe(order));
    }
    const Token sign = lex_.Next();
    if (!sign.Is('+') && !sign.Is('-')) Fail(sign, "expected '+' or '-' after the byte order, got " + Describe(sign));
    s.value_type = sign.Is('-') ? ValueType::kSigned : ValueType::kUnsigned;
    if (bits == 0 || bits > 64) Fail(length, "signal length must be 1..64 bits, got " + std::string(length.text));
    if (start_bit >= 512) Fail(start, "start bit " + std::string(start.text) + " lies beyond a 64-byte payload");
    s.start_bit = static_cast<uint32_t>(start_bit);
    s.length = static_cast<uint32_t>(bits);
    if (internal::SignalRequiredBytes(s) == 0) Fail(start, "signal " + s.name + " does not fit in a 64-byte payload");
    ExpectPunct('(');
    s.factor = ParseDouble(lex_.Next());
    ExpectPunct(',');
    s.offset = ParseDouble(lex_.Next());
    ExpectPunct(')');
    ExpectPunct('[');
    s.minimum = ParseDouble(lex_.Next());
    ExpectPunct('|');
    s.maximum = ParseDouble(lex_.Next());
    ExpectPunct(']');
    s.unit = internal::Unescape(Expect(TokenKind::kString, "a unit string").text);
    std::set<std::string_view> seen;
    // Receivers end with the line: a following unknown section must not be taken for one.
    while (!lex_.Peek().first_on_line && (lex_.Peek().kind == TokenKind::kIdentifier || lex_.Peek().Is(','))) {
      const Token r = lex_.Next();
      // Vector__XXX is the DBC's "no node" placeholder (cantools drops it too).
      if (r.kind == TokenKind::kIdentifier && r.text != kNoNode && seen.insert(r.text).second) s.receivers.emplace_back(r.text);
    }
    if (message_ == kDiscardedMessage) return;
    db_.messages[static_cast<size_t>(message_)].signals.push_back(std::move(s));
  }

  void ParseMuxIndicator(const Token& t, Signal& s) {
    const std::string_view v = t.text;
    if (v == "M") {
      s.mux_role = MuxRole::kMultiplexor;
      return;
    }
    size_t digits = 1;
    while (digits < v.size() && v[digits] >= '0' && v[digits] <= '9') ++digits;
    const bool extended = digits == v.size() - 1 && v.back() == 'M';
    if (v.size() < 2 || v[0] != 'm' || digits < 2 || (digits != v.size() && !extended)) {
      Fail(t, "expected a multiplexer indicator (M or mN) or ':', got " + Describe(t));
    }
    s.mux_role = MuxRole::kMultiplexed;
    std::from_chars(v.data() + 1, v.data() + digits, s.mux_value);
    if (extended) Warn(t, "extended multiplexing (" + std::string(v) + ") is not supported; " + s.name +
                              " is treated as multiplexed by value " + std::to_string(s.mux_value) + " only");
  }

  // CM_ "text"; | CM_ BU_ node "text"; | CM_ BO_ id "text"; | CM_ SG_ id signal "text"; | CM_ EV_ var "text";
  void ParseComment(const Token& cm) {
    const Token what = lex_.Next();
    if (what.kind == TokenKind::kString) {
      if (!db_.comment.empty()) db_.comment += '\n';
      db_.comment += internal::Unescape(what.text);
    } else if (what.IsIdentifier("BU_") || what.IsIdentifier("EV_")) {
      Expect(TokenKind::kIdentifier, "a name");
      Expect(TokenKind::kString, "a comment string");
    } else if (what.IsIdentifier("BO_") || what.kind == TokenKind::kNumber) {
      const Token id = what.kind == TokenKind::kNumber ? what : lex_.Next();
      if (what.kind == TokenKind::kNumber) {
        Warn(what, "message comment without 'BO_' (CM_ " + std::string(what.text) + " \"...\"): taken as the comment of message " +
                       std::string(what.text));
      }
      internal::PendingComment c;
      c.raw_id = ParseMessageId(id);
      c.at = cm;
      c.text = internal::Unescape(Expect(TokenKind::kString, "a comment string").text);
      refs_.comments.push_back(std::move(c));
    } else if (what.IsIdentifier("SG_")) {
      internal::PendingComment c;
      c.raw_id = ParseMessageId(lex_.Next());
      c.at = cm;
      if (lex_.Peek().kind == TokenKind::kString) {
        Warn(lex_.Peek(), "signal comment without a signal name (CM_ SG_ " + std::to_string(c.raw_id) + " \"...\"): ignored");
        lex_.Next();
      } else {
        c.signal = std::string(Expect(TokenKind::kIdentifier, "a signal name").text);
        c.text = internal::Unescape(Expect(TokenKind::kString, "a comment string").text);
        refs_.comments.push_back(std::move(c));
      }
    } else {
      Fail(what, "expected a comment string or BU_/BO_/SG_/EV_ after CM_, got " + Describe(what));
    }
    EndStatement(cm);
  }

  // BA_DEF_ [BU_|BO_|SG_|EV_] "name" type ...;  Only the names are kept (for GenMsgCycleTime).
  void ParseAttributeDefinition(const Token& ba_def) {
    if (lex_.Peek().kind == TokenKind::kIdentifier) lex_.Next();
    refs_.attribute_definitions.insert(internal::Unescape(Expect(TokenKind::kString, "an attribute name").text));
    SkipStatement(ba_def, true);
  }

  // BA_DEF_DEF_ "name" value;
  void ParseAttributeDefault(const Token& ba_def_def) {
    const std::string name = internal::Unescape(Expect(TokenKind::kString, "an attribute name").text);
    const Token value = lex_.Next();
    if (name == kCycleTimeAttribute) refs_.cycle_time_default_ms = ParseDouble(value);
    EndStatement(ba_def_def);
  }

  // BA_ "name" [BU_ node | BO_ id | SG_ id signal | EV_ var] value;
  void ParseAttribute(const Token& ba) {
    const std::string name = internal::Unescape(Expect(TokenKind::kString, "an attribute name").text);
    std::optional<uint32_t> message_id;
    const Token& kind = lex_.Peek();
    if (kind.IsIdentifier("BU_") || kind.IsIdentifier("EV_")) {
      lex_.Next();
      Expect(TokenKind::kIdentifier, "a name");
    } else if (kind.IsIdentifier("BO_")) {
      lex_.Next();
      message_id = ParseMessageId(lex_.Next());
    } else if (kind.IsIdentifier("SG_")) {
      lex_.Next();
      ParseMessageId(lex_.Next());
      Expect(TokenKind::kIdentifier, "a signal name");
    }
    const Token value = lex_.Next();
    if (value.kind != TokenKind::kNumber && value.kind != TokenKind::kString) Fail(value, "expected an attribute value, got " + Describe(value));
    if (message_id && name == kCycleTimeAttribute) {
      internal::PendingCycleTime c;
      c.raw_id = *message_id;
      c.at = ba;
      c.value_ms = ParseDouble(value);
      refs_.cycle_times.push_back(std::move(c));
    }
    EndStatement(ba);
  }

  // VAL_ id signal (value "text")* ;   or VAL_ env_var (value "text")* ; (ignored)
  void ParseValues(const Token& val) {
    internal::PendingValues v;
    v.at = val;
    const bool for_signal = lex_.Peek().kind == TokenKind::kNumber;
    if (for_signal) {
      v.raw_id = ParseMessageId(lex_.Next());
      v.signal = std::string(Expect(TokenKind::kIdentifier, "a signal name").text);
    } else {
      Expect(TokenKind::kIdentifier, "a message id or environment variable name");
    }
    while (lex_.Peek().kind == TokenKind::kNumber) {
      const int64_t raw = ParseInteger(lex_.Next());
      v.table[raw] = internal::Unescape(Expect(TokenKind::kString, "a value description string").text);
    }
    EndStatement(val);
    if (for_signal) refs_.values.push_back(std::move(v));
  }

  // SIG_VALTYPE_ id signal : type;   (0 integer, 1 float32, 2 float64)
  void ParseValueType(const Token& vt) {
    internal::PendingValueType p;
    p.at = vt;
    p.raw_id = ParseMessageId(lex_.Next());
    p.signal = std::string(Expect(TokenKind::kIdentifier, "a signal name").text);
    AcceptPunct(':');
    p.type_token = lex_.Next();
    const uint64_t type = ParseUnsigned(p.type_token);
    if (type > 2) Fail(p.type_token, "SIG_VALTYPE_ must be 0, 1 (float32) or 2 (float64)");
    p.type = static_cast<int>(type);
    EndStatement(vt);
    refs_.value_types.push_back(std::move(p));
  }

  std::string file_;
  internal::Lexer lex_;
  Database db_;
  int message_ = kNoMessage;  // index of the BO_ that SG_ lines belong to
  std::unordered_map<uint32_t, size_t> by_raw_id_;
  internal::References refs_;
};

}  // namespace

Database ParseDbcText(std::string_view text, const std::string& file_name_for_messages) {
  return Parser(text, file_name_for_messages).Parse();
}

Database ParseDbcFile(const std::string& path) {
  constexpr size_t kMaxDbcBytes = 64 << 20;  // 64 MiB; the largest real DBCs are a few MB
  std::string text;
  try {
    text = ReadWholeFile(path, kMaxDbcBytes);
  } catch (const Error& e) {
    throw DbcError(path, 0, 0, std::string("DBC file: ") + e.what());
  }
  Database db = ParseDbcText(text, path);
  auto log = internal::Logger();
  size_t signals = 0;
  for (const auto& m : db.messages) signals += m.signals.size();
  log->info("loaded {}: {} messages, {} signals, {} warnings", path, db.messages.size(), signals, db.warnings.size());
  constexpr size_t kWarningsLogged = 10;
  for (size_t i = 0; i < db.warnings.size() && i < kWarningsLogged; ++i) {
    const auto& w = db.warnings[i];
    log->warn("{}", FormatLocation(w.file, w.line, w.column, w.text));
  }
  if (db.warnings.size() > kWarningsLogged) log->warn("... and {} more warnings", db.warnings.size() - kWarningsLogged);
  return db;
}

}  // namespace ndsid::dbc
