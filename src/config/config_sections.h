// The configuration parser's sections (config.cc, ParseConfig), one reader each, in the order
// ParseConfig calls them (the order decides which of two errors a file reports first):
//   vehicle, source, dbc, signals (the roles and validity signals), sync, gate, identification
//   (with its parameters' box), adequacy, plausibility, lcm (publish), model (effects, formulas,
//   priors), and the top level's remaining keys (state, report, log level).
// Each reads one mapping through a YamlReader (unknown keys rejected by its Finish) and range-
// checks every number where it is read (docs/configuration.md lists the ranges).
#pragma once

#include <string>

#include "ndsid/config/config.h"
#include "yaml_reader.h"

namespace ndsid::config {

inline constexpr double kMaxTimeoutS = 60;         // signal staleness
inline constexpr double kMaxPhysical = 1e12;       // formula parameter bounds, prior values
inline constexpr double kMaxParameterBound = 1e9;  // m, Jz, cv, ch, lv, is box

// A path of the file, relative to its folder `base_dir` unless absolute.
std::string Resolve(const std::string& base_dir, const std::string& p);
void CheckRange(const YamlReader& r, const std::string& key, double v, double lo, double hi);
// Every number of the configuration is range-checked where it is read: an absurd value
// (status_rate_hz: 1e-300, sync.latency_s: 1e15) would otherwise overflow a conversion to a
// period or a count later.
double Ranged(const YamlReader& r, const std::string& key, double fallback, double lo, double hi);

void ReadVehicle(const YamlReader& v, VehicleConfig& vehicle);
void ReadSource(const YamlReader& s, const std::string& base_dir, SourceConfig& source);
// signals: every role (roles[i]) and the validity signals.
void ReadSignals(const YamlReader& sig, Config& c);
void ReadSync(const YamlReader& s, SyncConfig& sync);
void ReadGate(const YamlReader& g, GateConfig& gate);
// has_yaw_rate: the bus has a yaw rate (both outputs by default).
void ReadIdentification(const YamlReader& id, const std::string& base_dir, const VehicleConfig& vehicle, bool has_yaw_rate,
                        IdentificationConfig& ic);
void ReadAdequacy(const YamlReader& a, AdequacyConfig& adequacy);
void ReadPlausibility(const YamlReader& p, PlausibilityConfig& plausibility);
void ReadLcm(const YamlReader& l, LcmConfig& lcm);
// model: effects, formulas (Config::model_formulas), priors (IdentificationConfig::priors).
void ReadModel(const YamlReader& m, Config& c);
// identification.prior_from: the fleet prior's parameters (Jz, cv, ch per kg of this vehicle's
// mass; lv, is) as priors, where model.priors does not name them (called after ReadModel).
void ApplyFleetPrior(const std::string& config_path, const VehicleConfig& vehicle, IdentificationConfig& ic);
// Whether identification.prior_from names a fleet table (a .parquet file, read with prior_group).
bool NamesFleetTable(const std::string& prior_from);
// The top level's own keys: state_dir, state_unreadable, report_dir, log_level.
void ReadTopLevel(const YamlReader& top, const std::string& base_dir, Config& c);

}  // namespace ndsid::config
