// The one codec for learned state (docs/state-format.md): every stage writes its own values as
// JSON with nlohmann_json (ToJson), and reads them back through JsonIn, which checks type and
// presence and names the path of what is wrong ("state.accumulator.drives[3].end_ns: ...").
// The daemon's state file carries the document in CBOR, JSON's binary form; estimate.json and
// the desk's reports carry it as text. Non-finite numbers: CBOR keeps NaN and infinities, text
// JSON writes null, and JsonIn::Number reads null as NaN (the readers' range checks decide).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "ndsid/common/error.h"

namespace ndsid {

// Thrown for a document that does not have the expected shape; the message starts with the path.
class CodecError : public Error {
 public:
  using Error::Error;
};

class JsonIn {
 public:
  JsonIn(const nlohmann::json& value, std::string path) : v_(&value), path_(std::move(path)) {}

  const std::string& path() const { return path_; }
  const nlohmann::json& raw() const { return *v_; }
  [[noreturn]] void Fail(const std::string& what) const;

  bool Has(const char* key) const { return v_->is_object() && v_->contains(key); }
  JsonIn At(const char* key) const;       // an object's member; it must be there
  JsonIn At(size_t index) const;          // an array's element
  size_t Size(size_t max) const;          // an array's length, at most `max`

  double Number() const;                  // a number; null reads as NaN
  double Finite() const;                  // a finite number
  int64_t Int64() const;
  uint64_t UInt64() const;
  bool Bool() const;
  std::string String() const;
  // An array of numbers (null as NaN) of at most `max` entries.
  std::vector<double> Numbers(size_t max) const;
  // An array of strings of at most `max` entries.
  std::vector<std::string> Strings(size_t max) const;

  // Shorthands for a member.
  double Number(const char* key) const { return At(key).Number(); }
  double Finite(const char* key) const { return At(key).Finite(); }
  int64_t Int64(const char* key) const { return At(key).Int64(); }
  uint64_t UInt64(const char* key) const { return At(key).UInt64(); }
  bool Bool(const char* key) const { return At(key).Bool(); }
  std::string String(const char* key) const { return At(key).String(); }

  // A CBOR byte string written by FloatsToBinary: `per_row` floats a row; returns the floats.
  std::vector<float> Floats(size_t per_row, size_t max_rows) const;
  // A CBOR byte string written by DoublesToBinary: exactly `count` float64 values.
  std::vector<double> Doubles(size_t count) const;

 private:
  const nlohmann::json* v_;
  std::string path_;
};

// float32 values as a little-endian byte string (compact in CBOR; in text JSON nlohmann
// writes it as {"bytes": [...], "subtype": null}).
nlohmann::json FloatsToBinary(const float* values, size_t count);
// float64 values as a little-endian byte string (one CBOR value, whatever the count).
nlohmann::json DoublesToBinary(const double* values, size_t count);

// Limits a CBOR document must keep before it is built in memory, so that a crafted file cannot
// exhaust the stack (nesting) or the memory (values); a byte string counts as one value.
struct CborLimits {
  int max_depth = 32;
  size_t max_values = 3'000'000;  // a legitimate state's worst case is about 1.6 M (docs/state-format.md)
};
// Parses CBOR, checking the limits first; throws CodecError("<what>: ...").
nlohmann::json ParseCbor(std::string_view bytes, const std::string& what, const CborLimits& limits = {});
std::string ToCbor(const nlohmann::json& doc);

}  // namespace ndsid
