#include "ndsid/common/json_codec.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

namespace ndsid {

void JsonIn::Fail(const std::string& what) const { throw CodecError(path_ + ": " + what); }

JsonIn JsonIn::At(const char* key) const {
  if (!v_->is_object()) Fail("not an object");
  const auto it = v_->find(key);
  if (it == v_->end()) throw CodecError(path_ + "." + key + ": missing");
  return JsonIn(*it, path_ + "." + key);
}

JsonIn JsonIn::At(size_t index) const {
  if (!v_->is_array()) Fail("not an array");
  if (index >= v_->size()) Fail("no element " + std::to_string(index));
  return JsonIn((*v_)[index], path_ + "[" + std::to_string(index) + "]");
}

size_t JsonIn::Size(size_t max) const {
  if (!v_->is_array()) Fail("not an array");
  if (v_->size() > max) Fail(std::to_string(v_->size()) + " entries, at most " + std::to_string(max));
  return v_->size();
}

double JsonIn::Number() const {
  if (v_->is_null()) return std::numeric_limits<double>::quiet_NaN();
  if (!v_->is_number()) Fail("not a number");
  return v_->get<double>();
}

double JsonIn::Finite() const {
  const double v = Number();
  if (!std::isfinite(v)) Fail("not a finite number");
  return v;
}

int64_t JsonIn::Int64() const {
  if (v_->is_number_unsigned()) {
    const uint64_t u = v_->get<uint64_t>();
    if (u > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) Fail("integer out of range");
    return static_cast<int64_t>(u);
  }
  if (!v_->is_number_integer()) Fail("not an integer");
  return v_->get<int64_t>();
}

uint64_t JsonIn::UInt64() const {
  if (!v_->is_number_unsigned()) Fail(v_->is_number_integer() ? "negative" : "not a non-negative integer");
  return v_->get<uint64_t>();
}

bool JsonIn::Bool() const {
  if (!v_->is_boolean()) Fail("not true or false");
  return v_->get<bool>();
}

std::string JsonIn::String() const {
  if (!v_->is_string()) Fail("not a string");
  return v_->get<std::string>();
}

std::vector<double> JsonIn::Numbers(size_t max) const {
  const size_t n = Size(max);
  std::vector<double> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = At(i).Number();
  return out;
}

std::vector<std::string> JsonIn::Strings(size_t max) const {
  const size_t n = Size(max);
  std::vector<std::string> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = At(i).String();
  return out;
}

std::vector<float> JsonIn::Floats(size_t per_row, size_t max_rows) const {
  if (!v_->is_binary()) Fail("not a byte string");
  const auto& bytes = v_->get_binary();
  const size_t row_bytes = per_row * sizeof(float);
  if (bytes.size() % row_bytes != 0) Fail(std::to_string(bytes.size()) + " bytes, not whole rows of " + std::to_string(per_row) + " floats");
  if (bytes.size() / row_bytes > max_rows) Fail("more than " + std::to_string(max_rows) + " rows");
  std::vector<float> out(bytes.size() / sizeof(float));
  for (size_t i = 0; i < out.size(); ++i) {
    uint32_t u = 0;
    for (int b = 3; b >= 0; --b) u = (u << 8) | bytes[i * 4 + static_cast<size_t>(b)];
    out[i] = std::bit_cast<float>(u);
  }
  return out;
}

std::vector<double> JsonIn::Doubles(size_t count) const {
  if (!v_->is_binary()) Fail("not a byte string");
  const auto& bytes = v_->get_binary();
  if (bytes.size() != count * sizeof(double)) {
    Fail(std::to_string(bytes.size()) + " bytes, not " + std::to_string(count) + " float64 values");
  }
  std::vector<double> out(count);
  for (size_t i = 0; i < count; ++i) {
    uint64_t u = 0;
    for (int b = 7; b >= 0; --b) u = (u << 8) | bytes[i * 8 + static_cast<size_t>(b)];
    out[i] = std::bit_cast<double>(u);
  }
  return out;
}

nlohmann::json DoublesToBinary(const double* values, size_t count) {
  std::vector<uint8_t> bytes(count * sizeof(double));
  for (size_t i = 0; i < count; ++i) {
    const uint64_t u = std::bit_cast<uint64_t>(values[i]);
    for (size_t b = 0; b < 8; ++b) bytes[i * 8 + b] = static_cast<uint8_t>(u >> (8 * b));
  }
  return nlohmann::json::binary(std::move(bytes));
}

nlohmann::json FloatsToBinary(const float* values, size_t count) {
  std::vector<uint8_t> bytes(count * sizeof(float));
  for (size_t i = 0; i < count; ++i) {
    const uint32_t u = std::bit_cast<uint32_t>(values[i]);
    for (size_t b = 0; b < 4; ++b) bytes[i * 4 + b] = static_cast<uint8_t>(u >> (8 * b));
  }
  return nlohmann::json::binary(std::move(bytes));
}

namespace {

// A SAX pass that only counts: nesting depth and values, and stops at the first limit.
class LimitCheck final : public nlohmann::json::json_sax_t {
 public:
  explicit LimitCheck(const CborLimits& limits) : limits_(limits) {}
  std::string problem;

  bool null() override { return Value(); }
  bool boolean(bool) override { return Value(); }
  bool number_integer(number_integer_t) override { return Value(); }
  bool number_unsigned(number_unsigned_t) override { return Value(); }
  bool number_float(number_float_t, const string_t&) override { return Value(); }
  bool string(string_t&) override { return Value(); }
  bool binary(binary_t&) override { return Value(); }
  bool start_object(std::size_t) override { return Open(); }
  bool key(string_t&) override { return true; }
  bool end_object() override { return Close(); }
  bool start_array(std::size_t) override { return Open(); }
  bool end_array() override { return Close(); }
  bool parse_error(std::size_t position, const std::string&, const nlohmann::json::exception& e) override {
    problem = "byte " + std::to_string(position) + ": " + e.what();
    return false;
  }

 private:
  bool Value() {
    if (++values_ > limits_.max_values) {
      problem = "more than " + std::to_string(limits_.max_values) + " values";
      return false;
    }
    return true;
  }
  bool Open() {
    if (!Value()) return false;
    if (++depth_ > limits_.max_depth) {
      problem = "nested deeper than " + std::to_string(limits_.max_depth);
      return false;
    }
    return true;
  }
  bool Close() {
    --depth_;
    return true;
  }
  const CborLimits& limits_;
  int depth_ = 0;
  size_t values_ = 0;
};

}  // namespace

nlohmann::json ParseCbor(std::string_view bytes, const std::string& what, const CborLimits& limits) {
  LimitCheck check(limits);
  const auto* begin = reinterpret_cast<const uint8_t*>(bytes.data());
  bool ok = false;
  try {
    ok = nlohmann::json::sax_parse(begin, begin + bytes.size(), &check, nlohmann::json::input_format_t::cbor);
  } catch (const nlohmann::json::exception& e) {
    throw CodecError(what + ": " + e.what());
  }
  if (!ok) throw CodecError(what + ": " + (check.problem.empty() ? std::string("malformed CBOR") : check.problem));
  try {
    return nlohmann::json::from_cbor(begin, begin + bytes.size());
  } catch (const nlohmann::json::exception& e) {
    throw CodecError(what + ": " + e.what());
  }
}

std::string ToCbor(const nlohmann::json& doc) {
  std::string out;
  nlohmann::json::to_cbor(doc, out);
  return out;
}

}  // namespace ndsid
