// The factory: recognise a log file's format from its first bytes (decompressed when the file
// is gzip) and open the matching reader. What a file that is none of them looks like is named
// in the error, with what to do about it.
#include "ndsid/can/frame_log.h"

#include <zlib.h>

#include <cerrno>
#include <cstring>
#include <string_view>

#include "asc_reader.h"
#include "blf_reader.h"
#include "candump_line.h"
#include "mf4_reader.h"
#include "ndsid/can/candump_reader.h"
#include "ndsid/common/error.h"

namespace ndsid::can {
namespace {

constexpr size_t kSniffBytes = 8192;
constexpr const char* kSupported =
    "ndsid reads candump -l, Vector ASC and BLF, ASAM MF4 bus logging (docs/can-input.md)";

[[noreturn]] void Unsupported(const std::string& path, const std::string& looks_like, const std::string& todo) {
  throw ConfigError(FormatLocation(path, 0, 0, "not a CAN log ndsid reads: looks like " + looks_like + "; " + todo +
                                                   " (" + kSupported + ")"));
}

bool StartsWith(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

bool IStartsWith(std::string_view s, std::string_view prefix) {
  if (s.size() < prefix.size()) return false;
  for (size_t i = 0; i < prefix.size(); ++i) {
    const char a = static_cast<char>(s[i] >= 'A' && s[i] <= 'Z' ? s[i] - 'A' + 'a' : s[i]);
    if (a != prefix[i]) return false;
  }
  return true;
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Reads up to kSniffBytes of content (gzip decompressed), noting whether the file was gzip.
std::string Sniff(const std::string& path, bool& gzip) {
  gzFile f = gzopen(path.c_str(), "rb");
  if (f == nullptr) throw Error("log " + path + ": cannot open: " + std::strerror(errno));
  std::string head(kSniffBytes, '\0');
  const int n = gzread(f, head.data(), static_cast<unsigned>(head.size()));
  gzip = gzdirect(f) == 0;
  gzclose(f);
  head.resize(n > 0 ? static_cast<size_t>(n) : 0);
  return head;
}

// Known binary formats by magic bytes; nullptr for none.
const char* BinaryKind(std::string_view h, const char*& todo) {
  struct Magic {
    std::string_view bytes;
    const char* kind;
    const char* todo;
  };
  static const Magic kMagics[] = {
      {"\xd4\xc3\xb2\xa1", "a pcap capture", "replay it onto a vcan interface and record with `candump -l`"},
      {"\xa1\xb2\xc3\xd4", "a pcap capture", "replay it onto a vcan interface and record with `candump -l`"},
      {"\x4d\x3c\xb2\xa1", "a pcap capture", "replay it onto a vcan interface and record with `candump -l`"},
      {"\xa1\xb2\x3c\x4d", "a pcap capture", "replay it onto a vcan interface and record with `candump -l`"},
      {"\x0a\x0d\x0d\x0a", "a pcapng capture", "replay it onto a vcan interface and record with `candump -l`"},
      {"BZh", "a bzip2-compressed file", "decompress it first (bunzip2)"},
      {"\xfd" "7zXZ", "an xz-compressed file", "decompress it first (unxz)"},
      {"\x28\xb5\x2f\xfd", "a zstd-compressed file", "decompress it first (unzstd)"},
      {"PK\x03\x04", "a zip archive", "unpack it first"},
      {"\x89HDF", "an HDF5 file", "export the raw frames as candump -l, ASC, BLF or MF4"},
      {"SQLite format 3", "an SQLite database", "export the raw frames as candump -l, ASC, BLF or MF4"},
      {"%PDF", "a PDF document", "give the log file itself"},
  };
  for (const Magic& m : kMagics) {
    if (StartsWith(h, m.bytes)) {
      todo = m.todo;
      return m.kind;
    }
  }
  return nullptr;
}

}  // namespace

const char* LogFormatName(LogFormat format) {
  switch (format) {
    case LogFormat::kCandump: return "candump";
    case LogFormat::kAsc: return "Vector ASC";
    case LogFormat::kBlf: return "Vector BLF";
    case LogFormat::kMf4: return "ASAM MF4";
  }
  return "unknown";
}

LogFormat DetectLogFormat(const std::string& path) {
  bool gzip = false;
  const std::string head = Sniff(path, gzip);
  const std::string_view h(head);
  if (h.empty()) return LogFormat::kCandump;  // an empty log: no frames
  if (StartsWith(h, "LOGG")) return LogFormat::kBlf;
  if (StartsWith(h, "MDF     ") || StartsWith(h, "UnFinMF ")) {  // finalised, or as a logger left it
    if (gzip) Unsupported(path, "a gzip-compressed MF4 file", "decompress it first (gunzip); MF4 needs random access");
    if (h.size() >= 10 && h[8] < '4') {
      Unsupported(path, "an MDF 3 file", "convert it to MDF 4 (asammdf: MDF(f).convert('4.10').save(g))");
    }
    return LogFormat::kMf4;
  }
  const char* todo = nullptr;
  if (const char* kind = BinaryKind(h, todo)) Unsupported(path, kind, todo);
  size_t binary = 0;
  for (const char c : h) binary += (c == '\0' || (static_cast<unsigned char>(c) < 0x20 && c != '\n' && c != '\r' && c != '\t')) ? 1 : 0;
  if (binary > h.size() / 100 + 1) {
    char magic[16];
    std::snprintf(magic, sizeof magic, "%02x %02x %02x %02x", static_cast<unsigned char>(h[0]),
                  h.size() > 1 ? static_cast<unsigned char>(h[1]) : 0, h.size() > 2 ? static_cast<unsigned char>(h[2]) : 0,
                  h.size() > 3 ? static_cast<unsigned char>(h[3]) : 0);
    Unsupported(path, std::string("an unknown binary format (first bytes ") + magic + ")",
                "convert it to candump -l, Vector ASC/BLF or ASAM MF4");
  }
  // Text: decide on the first meaningful lines.
  size_t pos = 0;
  int lines = 0;
  std::string first_line;
  bool candump_seen = false;
  bool all_commas = true;
  while (pos < h.size() && lines < 20) {
    size_t end = h.find('\n', pos);
    const bool complete = end != std::string_view::npos;
    if (!complete) end = h.size();
    const std::string_view line = Trim(h.substr(pos, end - pos));
    pos = end + 1;
    if (line.empty()) continue;
    if (!complete && h.size() == kSniffBytes) break;  // cut by the sniff window
    if (line[0] == '#') continue;                         // candump comments
    ++lines;
    if (first_line.empty()) first_line = std::string(line.substr(0, 60));
    if (IStartsWith(line, "date ") || IStartsWith(line, "base hex") || IStartsWith(line, "base dec") ||
        IStartsWith(line, "begin triggerblock") || IStartsWith(line, "// version") ||
        IStartsWith(line, "internal events logged") || IStartsWith(line, "no internal events logged")) {
      return LogFormat::kAsc;
    }
    CanFrame frame;
    std::string_view bus;
    if (detail::ParseLine(line, frame, bus) == nullptr) candump_seen = true;
    if (line.find(',') == std::string_view::npos) all_commas = false;
    if (StartsWith(line, ";$FILEVERSION") || StartsWith(line, ";   Message Number")) {
      Unsupported(path, "a PEAK PCAN trace (.trc)", "convert it with python-can: python -m can.logconvert in.trc out.blf");
    }
    if (StartsWith(line, "***BUSMASTER")) {
      Unsupported(path, "a BUSMASTER log", "export it as Vector ASC or candump -l");
    }
  }
  if (candump_seen) return LogFormat::kCandump;
  if (lines == 0) return LogFormat::kCandump;  // only comments / blank lines
  if (first_line[0] == '(') return LogFormat::kCandump;  // damaged candump lines: counted as malformed
  if (all_commas && lines >= 1) {
    Unsupported(path, "CSV (first line '" + first_line + "')",
                "CSV has no standard CAN frame layout: write candump -l lines \"(sec.usec) can0 ID#DATA\"");
  }
  if (first_line[0] == '{' || first_line[0] == '[') {
    Unsupported(path, "JSON", "write the frames as candump -l lines \"(sec.usec) can0 ID#DATA\"");
  }
  if (first_line.find('[') != std::string::npos && (StartsWith(first_line, "can") || StartsWith(first_line, "vcan"))) {
    Unsupported(path, "candump screen output (no timestamps)", "record with `candump -l` (or -L) instead");
  }
  Unsupported(path, "text of an unknown format (first line '" + first_line + "')",
              "convert it to candump -l, Vector ASC/BLF or ASAM MF4");
}

std::unique_ptr<FrameLog> OpenFrameLog(const std::string& path) {
  switch (DetectLogFormat(path)) {
    case LogFormat::kCandump: return std::make_unique<CandumpReader>(path);
    case LogFormat::kAsc: return detail::OpenAscLog(path);
    case LogFormat::kBlf: return detail::OpenBlfLog(path);
    case LogFormat::kMf4: return detail::OpenMf4Log(path);
  }
  throw Error("log " + path + ": unknown format");
}

}  // namespace ndsid::can
