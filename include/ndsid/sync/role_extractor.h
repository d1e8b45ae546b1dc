// Decoded CAN frames -> role values in SI, fed to a SignalSync. Builds the DBC decoder for
// exactly the signals the configuration maps, applies unit and sign, filters by bus.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ndsid/can/can_frame.h"
#include "ndsid/config/config.h"
#include "ndsid/dbc/database.h"
#include "ndsid/dbc/decoder.h"
#include "ndsid/sync/signal_sync.h"

namespace ndsid::sync {

struct ExtractCounters {
  uint64_t frames = 0;       // frames offered
  uint64_t used = 0;         // frames that carried a mapped signal
  uint64_t unknown_id = 0;   // frames with no mapped signal (other traffic; not an error)
  uint64_t too_short = 0;    // frames shorter than a mapped signal needs
  uint64_t other_bus = 0;    // frames of a bus not selected
  uint64_t error_frames = 0; // CAN error frames
};

class RoleExtractor {
 public:
  // Throws ConfigError when a mapped signal is missing from the DBC. `db` must outlive this.
  RoleExtractor(const config::Config& config, const dbc::Database& db);

  // bus_names: the source's bus table (to honour config.source.bus).
  void Process(const can::CanFrame& frame, const std::vector<std::string>& bus_names, SignalSync& sync) noexcept;

  // CAN ids (with extended flag) the configuration needs: the SocketCAN kernel filter.
  struct Id {
    uint32_t id;
    bool extended;
  };
  std::vector<Id> NeededIds() const;

  const ExtractCounters& counters() const noexcept { return counters_; }

 private:
  struct Target {
    int role = -1;      // config::Role, or -1
    int validity = -1;  // index into config.validity, or -1
    int input = -1;     // >= 0: input `input` of role `role`'s expression
    bool clock = false; // this input's message is the expression's time base (its first input's)
  };
  // The latest value of each input of an expression role, and when it came.
  struct ExprInput {
    double value = 0;
    int64_t t_ns = 0;
    bool seen = false;
  };
  void EvaluateExpression(int role, int64_t t_ns, SignalSync& sync) noexcept;
  const config::Config& config_;
  dbc::Decoder decoder_;
  std::vector<std::vector<Target>> targets_;  // per decoder signal index
  std::vector<dbc::DecodedValue> scratch_;
  std::vector<std::vector<ExprInput>> expr_inputs_;  // per role (empty for single-signal roles)
  std::vector<double> expr_values_;                  // scratch: the inputs in expression order
  int wanted_bus_ = -2;  // -2 unresolved, -1 all, else index
  ExtractCounters counters_;
};

}  // namespace ndsid::sync
