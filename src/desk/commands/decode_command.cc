// `ndsid decode`: a CAN log (any format of can::OpenFrameLog) decoded with a DBC, as CSV on stdout (like `cantools decode`,
// one row per signal value). Malformed lines, unknown ids and short frames are counted and
// summarised on stderr at the end.
#include <charconv>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "command_registry.h"
#include "ndsid/can/frame_log.h"
#include "ndsid/common/error.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"
#include "number_format.h"

namespace ndsid::desk {
namespace {

struct DecodeArgs {
  std::string dbc;
  std::string log;
  std::vector<std::string> messages;
  std::vector<std::string> signals;
  std::string bus;  // empty: every bus
};

// The signals of the named messages (all messages if none named), restricted to the named
// signals if any. Names that select nothing are configuration errors.
std::vector<dbc::SignalSelector> Select(const dbc::Database& db, const DecodeArgs& a) {
  const std::set<std::string> messages(a.messages.begin(), a.messages.end());
  const std::set<std::string> signals(a.signals.begin(), a.signals.end());
  for (const auto& m : messages) {
    if (db.FindMessage(m) == nullptr) throw ConfigError("--messages: " + a.dbc + " has no message " + m);
  }
  std::vector<dbc::SignalSelector> selection;
  std::set<std::string> found;
  for (const auto& m : db.messages) {
    if (!messages.empty() && messages.count(m.name) == 0) continue;
    for (const auto& s : m.signals) {
      if (!signals.empty() && signals.count(s.name) == 0) continue;
      selection.push_back({m.name, s.name});
      found.insert(s.name);
    }
  }
  for (const auto& s : signals) {
    if (found.count(s) == 0) throw ConfigError("--signals: no selected message of " + a.dbc + " has a signal " + s);
  }
  if (selection.empty()) throw ConfigError("nothing to decode: the selection has no signals");
  return selection;
}

// Buffered CSV output: rows are formatted in place (std::to_chars, no printf parsing, no locale)
// and written in 1 MiB blocks.
class CsvOut {
 public:
  explicit CsvOut(std::FILE* f) : file_(f), buffer_(1 << 20) {}
  ~CsvOut() { Flush(); }
  // Room for at least `n` more bytes.
  char* Reserve(size_t n) {
    if (used_ + n > buffer_.size()) {
      Flush();
      if (n > buffer_.size()) buffer_.resize(n);
    }
    return buffer_.data() + used_;
  }
  void Commit(char* end) { used_ = static_cast<size_t>(end - buffer_.data()); }
  void Append(std::string_view s) {
    char* p = Reserve(s.size());
    std::memcpy(p, s.data(), s.size());
    Commit(p + s.size());
  }
  void Flush() {
    if (used_ && std::fwrite(buffer_.data(), 1, used_, file_) != used_) write_failed_ = true;
    used_ = 0;
  }
  bool write_failed() const { return write_failed_ || std::ferror(file_); }

 private:
  std::FILE* file_;
  std::vector<char> buffer_;
  size_t used_ = 0;
  bool write_failed_ = false;
};

// "sec.usec," from nanoseconds, exact (no floating point), as candump writes it.
char* WriteTime(int64_t ns, char* p) {
  const int64_t us = (ns >= 0 ? ns + 500 : ns - 500) / 1000;
  uint64_t abs_us = us < 0 ? static_cast<uint64_t>(-(us + 1)) + 1 : static_cast<uint64_t>(us);
  if (us < 0) *p++ = '-';
  p = std::to_chars(p, p + 24, abs_us / 1000000).ptr;
  *p++ = '.';
  uint64_t frac = abs_us % 1000000;
  for (int i = 5; i >= 0; --i) p[i] = static_cast<char>('0' + frac % 10), frac /= 10;
  p += 6;
  *p++ = ',';
  return p;
}

// One decoded value on its way from the reader to the writer thread.
struct Row {
  int64_t t_ns;
  int32_t signal;
  double value;
};

// Batches of rows handed from the reading thread to the writing thread: at most kInFlight full
// batches wait, so memory stays bounded whatever the log's size; emptied batches come back.
class RowQueue {
 public:
  static constexpr size_t kRows = 1 << 16;
  static constexpr size_t kInFlight = 4;
  std::vector<Row> Empty() {
    std::unique_lock<std::mutex> lock(mu_);
    if (free_.empty()) {
      std::vector<Row> b;
      b.reserve(kRows);
      return b;
    }
    std::vector<Row> b = std::move(free_.back());
    free_.pop_back();
    return b;
  }
  void Push(std::vector<Row>&& b) {
    std::unique_lock<std::mutex> lock(mu_);
    room_.wait(lock, [&] { return full_.size() < kInFlight; });
    full_.push_back(std::move(b));
    ready_.notify_one();
  }
  void Close() {
    std::unique_lock<std::mutex> lock(mu_);
    closed_ = true;
    ready_.notify_one();
  }
  // The next full batch; false once closed and drained.
  bool Pop(std::vector<Row>& b) {
    std::unique_lock<std::mutex> lock(mu_);
    ready_.wait(lock, [&] { return !full_.empty() || closed_; });
    if (full_.empty()) return false;
    b = std::move(full_.front());
    full_.pop_front();
    room_.notify_one();
    return true;
  }
  void Recycle(std::vector<Row>&& b) {
    b.clear();
    std::unique_lock<std::mutex> lock(mu_);
    free_.push_back(std::move(b));
  }

 private:
  std::mutex mu_;
  std::condition_variable ready_, room_;
  std::deque<std::vector<Row>> full_;
  std::vector<std::vector<Row>> free_;
  bool closed_ = false;
};

int Run(const DecodeArgs& a) {
  const dbc::Database db = dbc::ParseDbcFile(a.dbc);
  const std::vector<dbc::SignalSelector> selection = Select(db, a);
  const dbc::Decoder decoder(db, selection);
  const std::unique_ptr<can::FrameLog> log = can::OpenFrameLog(a.log);
  can::FrameLog& reader = *log;

  struct Counts {
    uint64_t frames = 0, decoded = 0, values = 0, unknown_id = 0, too_short = 0, not_data = 0, other_bus = 0;
  } n;
  std::vector<can::CanFrame> frames(512);
  std::vector<dbc::DecodedValue> out(decoder.max_signals_per_message());
  // "message,signal," per selected signal, formatted once.
  std::vector<std::string> names;
  for (const auto& sel : decoder.signals()) names.push_back(sel.message->name + "," + sel.signal->name + ",");
  CsvOut csv(stdout);
  csv.Append("t,message,signal,value\n");
  // Two threads: this one reads and decodes, the writer formats and writes (each about half
  // of the work; bench/run_decode_csv_bench.sh). The rows keep their order.
  RowQueue queue;
  std::thread writer([&] {
    std::vector<Row> batch;
    char time_text[48];
    size_t time_len = 0;
    int64_t time_of_text = 0;
    bool have_time = false;
    while (queue.Pop(batch)) {
      for (const Row& r : batch) {
        if (!have_time || r.t_ns != time_of_text) {  // a frame's values share its time stamp
          time_len = static_cast<size_t>(WriteTime(r.t_ns, time_text) - time_text);
          time_of_text = r.t_ns;
          have_time = true;
        }
        const std::string& name = names[static_cast<size_t>(r.signal)];
        char* p = csv.Reserve(time_len + name.size() + 32);
        std::memcpy(p, time_text, time_len);
        p += time_len;
        std::memcpy(p, name.data(), name.size());
        p += name.size();
        p = FormatG10(p, r.value);  // exactly printf's %.10g, from the shortest digits
        *p++ = '\n';
        csv.Commit(p);
      }
      queue.Recycle(std::move(batch));
    }
  });
  std::vector<Row> batch = queue.Empty();
  for (;;) {
    const can::ReadResult r = reader.Read(frames, 0);
    for (size_t i = 0; i < r.count; ++i) {
      const can::CanFrame& f = frames[i];
      ++n.frames;
      if (!a.bus.empty() && (f.bus >= reader.bus_names().size() || reader.bus_names()[f.bus] != a.bus)) {
        ++n.other_bus;
        continue;
      }
      size_t count = 0;
      switch (decoder.Decode(f, out, count)) {
        case dbc::DecodeVerdict::kDecoded: ++n.decoded; break;
        case dbc::DecodeVerdict::kTooShort: ++n.too_short; break;
        case dbc::DecodeVerdict::kUnknownId: ++n.unknown_id; break;
        case dbc::DecodeVerdict::kNotData: ++n.not_data; break;
      }
      for (size_t k = 0; k < count; ++k) batch.push_back({f.timestamp_ns, out[k].signal_index, out[k].value});
      n.values += count;
      if (batch.size() >= RowQueue::kRows) {
        queue.Push(std::move(batch));
        batch = queue.Empty();
      }
    }
    if (r.state == can::SourceState::kEnd) break;
  }
  if (!batch.empty()) queue.Push(std::move(batch));
  queue.Close();
  writer.join();
  csv.Flush();
  std::fflush(stdout);
  if (csv.write_failed()) {
    std::cerr << "ndsid decode: writing the CSV failed (disk full or closed pipe)\n";
    return kExitIo;
  }

  const auto& c = reader.counters();
  std::cerr << "ndsid decode: " << n.frames << " frames, " << n.decoded << " decoded, " << n.values << " values; "
            << n.unknown_id << " unknown id, " << n.too_short << " too short, " << n.not_data << " remote/error, "
            << n.other_bus << " on other buses, " << c.malformed << " malformed "
            << (reader.format() == can::LogFormat::kCandump || reader.format() == can::LogFormat::kAsc ? "lines" : "records")
            << " (" << can::LogFormatName(reader.format()) << ")\n";
  for (const auto& m : reader.first_malformed()) std::cerr << "  " << reader.Locate(m) << "\n";
  if (!reader.io_error().empty()) {  // truncated or unreadable: the CSV above is incomplete
    std::cerr << "ndsid decode: " << a.log << ": not read to its end: reading stopped after " << c.frames
              << " frames: " << reader.io_error() << "\n";
    return kExitIo;
  }
  return 0;
}

void RegisterDecode(CLI::App& parent, int& exit_code) {
  auto args = std::make_shared<DecodeArgs>();
  auto* cmd = parent.add_subcommand("decode", "Decode a CAN log (candump, ASC, BLF, MF4) with a DBC; CSV t,message,signal,value on stdout");
  cmd->add_option("--dbc", args->dbc, "DBC file")->required()->check(CLI::ExistingFile);
  cmd->add_option("--log", args->log, "CAN log: candump -l (plain or gzip), Vector ASC/BLF, ASAM MF4 bus logging")->required()->check(CLI::ExistingFile);
  cmd->add_option("--messages", args->messages, "only these messages (comma-separated names)")->delimiter(',');
  cmd->add_option("--signals", args->signals, "only these signals (comma-separated names)")->delimiter(',');
  cmd->add_option("--bus", args->bus, "only frames from this interface, e.g. can0 (default: all)");
  cmd->callback([args, &exit_code] { exit_code = Run(*args); });
}

}  // namespace
}  // namespace ndsid::desk

NDSID_REGISTER_COMMAND(decode, ndsid::desk::RegisterDecode);
