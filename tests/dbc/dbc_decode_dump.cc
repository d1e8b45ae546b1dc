// Test helper for cantools_crosscheck.py: prints what our parser and decoder make of a DBC,
// as JSON lines, so that an independent implementation (cantools) can be compared with it.
//
//   dbc_decode_dump info DBC              one line per warning, then one per message
//   dbc_decode_dump decode DBC PAYLOADS   PAYLOADS lines: "<index> <id hex> <extended 0|1> <data hex>"
//                                         output: {"i":index,"verdict":"...","values":{signal: value}}
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"

namespace {

using namespace ndsid::dbc;

std::string Json(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;  // bytes >= 0x80 pass through (the files are ASCII or UTF-8)
    }
  }
  return out + "\"";
}

std::string Json(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "Infinity" : "-Infinity";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

const char* Name(ByteOrder o) { return o == ByteOrder::kBigEndian ? "big_endian" : "little_endian"; }
const char* Name(ValueType t) {
  switch (t) {
    case ValueType::kSigned: return "signed";
    case ValueType::kFloat32: return "float32";
    case ValueType::kFloat64: return "float64";
    case ValueType::kUnsigned: break;
  }
  return "unsigned";
}
const char* Name(DecodeVerdict v) {
  switch (v) {
    case DecodeVerdict::kDecoded: return "decoded";
    case DecodeVerdict::kUnknownId: return "unknown_id";
    case DecodeVerdict::kTooShort: return "too_short";
    case DecodeVerdict::kNotData: return "not_data";
  }
  return "?";
}

int Info(const Database& db) {
  for (const auto& w : db.warnings) {
    std::cout << "{\"warning\":{\"line\":" << w.line << ",\"column\":" << w.column << ",\"text\":" << Json(w.text) << "}}\n";
  }
  for (const auto& m : db.messages) {
    std::cout << "{\"message\":{\"id\":" << m.id << ",\"extended\":" << (m.extended ? "true" : "false")
              << ",\"name\":" << Json(m.name) << ",\"length\":" << m.length << ",\"sender\":" << Json(m.sender)
              << ",\"comment\":" << Json(m.comment) << ",\"cycle_time\":" << (m.cycle_time_ms ? Json(*m.cycle_time_ms) : "null")
              << ",\"signals\":[";
    for (size_t i = 0; i < m.signals.size(); ++i) {
      const Signal& s = m.signals[i];
      std::cout << (i ? "," : "") << "{\"name\":" << Json(s.name) << ",\"start\":" << s.start_bit << ",\"length\":" << s.length
                << ",\"byte_order\":\"" << Name(s.byte_order) << "\",\"type\":\"" << Name(s.value_type)
                << "\",\"factor\":" << Json(s.factor) << ",\"offset\":" << Json(s.offset) << ",\"minimum\":" << Json(s.minimum)
                << ",\"maximum\":" << Json(s.maximum) << ",\"unit\":" << Json(s.unit) << ",\"comment\":" << Json(s.comment)
                << ",\"mux\":" << (s.mux_role == MuxRole::kMultiplexor ? "\"M\"" : s.mux_role == MuxRole::kMultiplexed ? std::to_string(s.mux_value) : "null")
                << ",\"choices\":{";
      bool first = true;
      for (const auto& [raw, text] : s.value_table) {
        std::cout << (first ? "" : ",") << "\"" << raw << "\":" << Json(text);
        first = false;
      }
      std::cout << "},\"receivers\":[";
      for (size_t r = 0; r < s.receivers.size(); ++r) std::cout << (r ? "," : "") << Json(s.receivers[r]);
      std::cout << "]}";
    }
    std::cout << "]}}\n";
  }
  return 0;
}

int Decode(const Database& db, const std::string& payload_path) {
  const Decoder decoder(db);
  std::vector<DecodedValue> out(decoder.max_signals_per_message());
  std::ifstream in(payload_path);
  if (!in) {
    std::cerr << "cannot open " << payload_path << "\n";
    return 2;
  }
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string index;
    std::string id_hex;
    int extended = 0;
    std::string data_hex;
    fields >> index >> id_hex >> extended >> data_hex;
    ndsid::can::CanFrame frame;
    frame.id = static_cast<uint32_t>(std::stoul(id_hex, nullptr, 16));
    frame.flags = extended ? ndsid::can::kFlagExtended : 0;
    frame.len = static_cast<uint8_t>(data_hex.size() / 2);
    if (frame.len > 8) frame.flags |= ndsid::can::kFlagFd;
    for (size_t b = 0; b < frame.len; ++b) frame.data[b] = static_cast<uint8_t>(std::stoul(data_hex.substr(2 * b, 2), nullptr, 16));
    size_t count = 0;
    const DecodeVerdict verdict = decoder.Decode(frame, out, count);
    std::cout << "{\"i\":" << index << ",\"verdict\":\"" << Name(verdict) << "\",\"values\":{";
    for (size_t k = 0; k < count; ++k) {
      std::cout << (k ? "," : "") << Json(decoder.signals()[static_cast<size_t>(out[k].signal_index)].signal->name) << ":"
                << Json(out[k].value);
    }
    std::cout << "}}\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (argc < 3 || (mode != "info" && mode != "decode") || (mode == "decode" && argc < 4)) {
    std::cerr << "usage: dbc_decode_dump info DBC | dbc_decode_dump decode DBC PAYLOADS\n";
    return 2;
  }
  spdlog::set_default_logger(spdlog::stderr_color_mt("dump"));  // stdout carries the JSON
  spdlog::set_level(spdlog::level::err);
  try {
    const Database db = ParseDbcFile(argv[2]);
    return mode == "info" ? Info(db) : Decode(db, argv[3]);
  } catch (const DbcError& e) {
    std::cout << "{\"error\":" << Json(e.what()) << ",\"line\":" << e.line() << ",\"column\":" << e.column() << "}\n";
    return 3;
  }
}
