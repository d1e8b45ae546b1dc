// Private to `ndsid init` (vehicle_init.cc): the decoded bus, candidates by name, the 20 Hz grid.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "ndsid/can/frame_log.h"
#include "ndsid/dbc/database.h"
#include "vehicle_init.h"

namespace ndsid::desk::init_detail {

// Every value of one signal on the bus it was seen most on.
struct SignalSeries {
  const dbc::Message* message = nullptr;
  const dbc::Signal* signal = nullptr;
  uint16_t bus = 0;
  std::vector<double> t;  // s since the first frame
  std::vector<double> v;  // physical value (DBC factor and offset applied)
  double period_s = 0;    // median spacing
  double min = 0, max = 0;
  bool varies = false;    // at least three distinct values
};

struct BusData {
  std::vector<SignalSeries> signals;
  std::vector<std::string> bus_names;
  std::map<std::string, uint16_t> message_bus;  // message name -> bus index used
  double t0 = 0, t1 = 0;                        // s, relative to the first frame (t0 = 0)
  const std::string& BusOf(const std::string& message) const;
  int Find(const std::string& message, const std::string& signal) const;  // -1 if absent
};

// Decodes the log (only `bus` if not empty) up to `max_frames` frames. Counts the frames read
// into `frames`; `truncated` when it stopped at the limit.
BusData CollectSignals(const dbc::Database& db, can::FrameLog& log, const std::string& bus, uint64_t max_frames,
                       uint64_t& frames, bool& truncated);

enum class RoleKind { kSteer, kSpeed, kLatAccel, kYawRate, kLongAccel, kWheelSpeed };

// A role candidate: one signal, or several of one message combined.
struct Source {
  enum class Combine { kSingle, kSum, kDifference, kSignMagnitude };
  std::vector<int> terms;  // indices into BusData::signals
  Combine combine = Combine::kSingle;
  std::string expression;  // MESSAGE.SIGNAL, or the role expression
  std::string unit;        // DBC unit of the first term
  std::string comment;     // DBC comment of the first term (and its message)
  int name_score = 0;
  std::string pair_evidence;  // why several signals were combined
};

// Varying signals named like `kind`, best names first, at most `top`; coarse+fine and
// sign+magnitude pairs of one message are combined.
std::vector<Source> Candidates(const BusData& data, RoleKind kind, size_t top);

void SetSource(RoleProposal& p, const Source& s, const BusData& data);

// Sample-and-hold onto a fixed grid; NaN where the last value is stale (older than
// max(0.5 s, 5 periods)) or absent; then a centred 1 s moving average (NaN if any value in it is).
class Grid {
 public:
  Grid(const BusData& data, double rate_hz);
  const std::vector<double>& Of(const Source& s);
  size_t size() const { return n_; }

 private:
  const std::vector<double>& OfSignal(int index);
  const BusData& data_;
  double rate_hz_;
  size_t n_;
  std::unordered_map<int, std::vector<double>> signals_;
  std::map<std::string, std::vector<double>> sources_;
};

struct UnitOption {
  const char* name;  // as the config writes it
  double to_si;
  std::vector<std::string> aliases;  // lower-case DBC spellings
};
const std::vector<UnitOption>& SpeedUnits();
const std::vector<UnitOption>& YawUnits();
const std::vector<UnitOption>& AccelUnits();
const std::vector<UnitOption>& SteerUnits();
int MatchUnit(const std::vector<UnitOption>& options, const std::string& dbc_unit);  // -1 unknown

// +1 when a DBC comment says positive to the left (counter-clockwise), -1 to the right, else 0.
int CommentDirection(const std::string& comment);

}  // namespace ndsid::desk::init_detail
