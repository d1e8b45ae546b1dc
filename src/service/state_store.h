// The daemon's learned state on disk: one versioned file per vehicle in config.state_dir,
// written atomically (WriteFileAtomically), checked when read. A corrupt or incompatible file
// is moved aside as <file>.corrupt-<UTC time>, a file of another vehicle as
// <file>.foreign-<UTC time>; the daemon then starts fresh instead of dying, and never loads
// another vehicle's state.
//
// File layout (docs/daemon.md):
//   NDSID-STATE <format version>\n
//   vehicle <config vehicle.name>\n
//   payload_bytes <n>\n
//   payload_fnv1a64 <16 hex digits>\n
//   \n
//   <payload: one document in CBOR (docs/state-format.md): data_time_ns, saved_unix_ns,
//    identifications, last_fit_gated_hours, accumulator, adequacy, estimate (null: none yet),
//    standstill (the window's stops)>
// Version 1 files (a payload of text and binary sections) still load: state_migration.h turns
// them into the same document.
//
// Threads: CaptureState/RestoreState on the reading thread (they touch the pipeline); Encode and
// StateStore::Save may run on the persist helper (they touch only the captured LearnedState).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "ndsid/common/error.h"
#include "ndsid/pipeline/pipeline.h"

namespace ndsid::service {

inline constexpr int kStateFormatVersion = 2;

struct LearnedState {
  std::string vehicle;
  int64_t data_time_ns = 0;       // newest frame time the state has seen (data clock)
  int64_t saved_unix_ns = 0;      // wall clock at capture
  int32_t identifications = 0;    // fits accepted since the state began
  double last_fit_gated_hours = -1;
  nlohmann::json accumulator;     // stats::Accumulator::ToJson()
  nlohmann::json adequacy;        // adequacy::Tracker::ToJson()
  std::optional<pipeline::Estimate> last_estimate;
  std::vector<gate::StandstillStop> stops;  // the window's standstill stops (evidence)
  // The incremental prior (docs/incremental.md); absent in older files and after a failed fit.
  // A damaged one is dropped with a warning (the next fit then covers the whole window), the
  // rest of the state is kept.
  std::shared_ptr<const identify::LinearizedWindow> linearized;
};

// At most this many stops in a state file: as many as the pipeline keeps.
inline constexpr size_t kMaxPersistedStops = pipeline::Pipeline::kMaxStops;

// Why a file could not be used.
class StateFileError : public Error {
 public:
  enum class Kind { kCorrupt, kIncompatible, kForeign };
  StateFileError(Kind kind, const std::string& what) : Error(what), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

std::string EncodeState(const LearnedState& state);
// Throws StateFileError: kForeign when the file belongs to another vehicle than `vehicle`.
LearnedState DecodeState(const std::string& bytes, const std::string& vehicle);

uint64_t Fnv1a64(std::string_view bytes);
// "example-cmax" -> "example-cmax.ndsid-state"; characters outside [A-Za-z0-9._-] become '_'.
std::string StateFileName(const std::string& vehicle);

class StateStore {
 public:
  StateStore(std::string state_dir, std::string vehicle);
  const std::string& path() const { return path_; }

  struct LoadResult {
    std::optional<LearnedState> state;  // empty: start fresh
    std::string message;                // what happened, for the log
    // The file exists but cannot be read (permissions, I/O error): the daemon stops rather than
    // start fresh and overwrite what it learned at the first persist.
    bool unreadable = false;
  };
  // Never throws for a bad file: it is moved aside (Quarantine) and reported in `message`.
  LoadResult Load();
  // Removes the temporary files an interrupted atomic write of this state left in state_dir
  // (".<file>.tmp<pid>.<n>"); returns how many.
  int RemoveTemporaries() const;
  // Atomic write (creates state_dir); throws ndsid::Error.
  void Save(const LearnedState& state) const;
  // Moves the file aside as <path>.<tag>-<UTC time>; returns the new path ("" when it failed).
  std::string Quarantine(const std::string& tag) const;

 private:
  std::string dir_;
  std::string vehicle_;
  std::string path_;
};

// The pipeline's learned state, and back. Restore checks what it restores: statistics that are
// malformed or non-finite throw StateFileError(kCorrupt) and leave the pipeline untouched; a
// last estimate with a non-finite value or a parameter outside the configured box is dropped
// (returned in `dropped_reason`), the statistics kept.
LearnedState CaptureState(const pipeline::Pipeline& pipeline, const config::Config& config, int32_t identifications);
void RestoreState(pipeline::Pipeline& pipeline, const config::Config& config, const LearnedState& state,
                  std::string& dropped_reason);
// Why an estimate may not be restored under `config` ("" = fine).
std::string CheckEstimate(const pipeline::Estimate& e, const config::Config& config);

}  // namespace ndsid::service
