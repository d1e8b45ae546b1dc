// Tokenizer for DBC text: identifiers, numbers, strings (may span lines, \" and \\ escapes)
// and the punctuation : ; , | @ ( ) [ ] + -. Private to the dbc stage.
#pragma once

#include <string>
#include <string_view>

namespace ndsid::dbc::internal {

enum class TokenKind { kIdentifier, kNumber, kString, kPunct, kEnd };

struct Token {
  TokenKind kind = TokenKind::kEnd;
  std::string_view text;  // strings: between the quotes, escapes not yet resolved
  int line = 0;           // 1-based
  int column = 0;         // 1-based, in bytes
  bool first_on_line = false;  // no other token precedes it on its line

  bool Is(char punct) const { return kind == TokenKind::kPunct && text.size() == 1 && text[0] == punct; }
  bool IsIdentifier(std::string_view word) const { return kind == TokenKind::kIdentifier && text == word; }
};

class Lexer {
 public:
  // `file` names the text in DbcErrors (unterminated string, stray character).
  Lexer(std::string_view text, const std::string& file);

  const Token& Peek() const { return next_; }
  Token Next();

 private:
  Token Scan();

  std::string_view text_;
  const std::string& file_;
  size_t pos_ = 0;
  int line_ = 1;
  size_t line_start_ = 0;
  int last_token_line_ = 0;
  Token next_;
};

// The string's text with \" and \\ resolved.
std::string Unescape(std::string_view raw);

// DBC section keywords (a token that is one of these and first on its line starts a statement).
bool IsKeyword(std::string_view word);

}  // namespace ndsid::dbc::internal
