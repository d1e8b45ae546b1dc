#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <limits>

#include "ndsid/common/atomic_file.h"
#include "ndsid/common/json_codec.h"
#include "ndsid/pipeline/estimate_codec.h"
#include "state_migration.h"
#include "state_store.h"

namespace ndsid::service {

namespace {

constexpr std::string_view kMagic = "NDSID-STATE";
constexpr double kBoxSlack = 1e-9;  // relative: a value on the box edge is inside

std::string OneLine(std::string s) {
  for (char& c : s) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return s;
}

// The document (docs/state-format.md) -> LearnedState; the statistics stay documents until
// RestoreState checks them against the configuration.
LearnedState FromDocument(const nlohmann::json& doc, const std::string& vehicle) {
  const JsonIn in(doc, "state");
  LearnedState st;
  st.vehicle = vehicle;
  st.data_time_ns = in.Int64("data_time_ns");
  st.saved_unix_ns = in.Int64("saved_unix_ns");
  const int64_t ids = in.Int64("identifications");
  if (ids < 0 || ids > std::numeric_limits<int32_t>::max()) in.At("identifications").Fail("out of range");
  st.identifications = static_cast<int32_t>(ids);
  st.last_fit_gated_hours = in.Number("last_fit_gated_hours");
  if (!in.At("accumulator").raw().is_object()) in.At("accumulator").Fail("not an object");
  if (!in.At("adequacy").raw().is_object()) in.At("adequacy").Fail("not an object");
  st.accumulator = in.At("accumulator").raw();
  st.adequacy = in.At("adequacy").raw();
  if (!in.At("estimate").raw().is_null()) st.last_estimate = pipeline::EstimateFromJson(in.At("estimate"));
  st.stops = pipeline::StopsFromJson(in.At("standstill"), kMaxPersistedStops);
  if (in.Has("linearized") && !in.At("linearized").raw().is_null()) {
    try {
      st.linearized = std::make_shared<const identify::LinearizedWindow>(identify::LinearizedWindow::FromJson(in.At("linearized")));
    } catch (const CodecError& e) {
      spdlog::warn("state: the incremental prior is dropped ({}); the next identification refits the whole window", e.what());
    }
  }
  return st;
}

std::string UtcStamp() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%dT%H%M%SZ", &tm);
  return buf;
}

}  // namespace

uint64_t Fnv1a64(std::string_view bytes) {
  uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 0x100000001b3ull;
  }
  return h;
}

std::string StateFileName(const std::string& vehicle) {
  std::string s = vehicle;
  for (char& c : s) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
    if (!ok) c = '_';
  }
  if (s.empty() || s[0] == '.') s.insert(s.begin(), '_');
  return s + ".ndsid-state";
}

std::string EncodeState(const LearnedState& st) {
  nlohmann::json doc;
  doc["data_time_ns"] = st.data_time_ns;
  doc["saved_unix_ns"] = st.saved_unix_ns;
  doc["identifications"] = st.identifications;
  doc["last_fit_gated_hours"] = st.last_fit_gated_hours;
  doc["accumulator"] = st.accumulator;
  doc["adequacy"] = st.adequacy;
  doc["estimate"] = st.last_estimate ? pipeline::EstimateToJson(*st.last_estimate) : nlohmann::json();
  doc["standstill"] = pipeline::StopsToJson(st.stops);
  if (st.linearized) doc["linearized"] = st.linearized->ToJson();
  const std::string payload = ToCbor(doc);
  char checksum[17];
  std::snprintf(checksum, sizeof checksum, "%016llx", static_cast<unsigned long long>(Fnv1a64(payload)));
  std::string out;
  out += std::string(kMagic) + ' ' + std::to_string(kStateFormatVersion) + '\n';
  out += "vehicle " + OneLine(st.vehicle) + '\n';
  out += "payload_bytes " + std::to_string(payload.size()) + '\n';
  out += std::string("payload_fnv1a64 ") + checksum + '\n';
  out += '\n';
  out += payload;
  return out;
}

LearnedState DecodeState(const std::string& bytes, const std::string& vehicle) {
  using K = StateFileError::Kind;
  // Header: four lines and a blank one.
  std::string lines[5];
  size_t pos = 0;
  for (std::string& l : lines) {
    const size_t nl = bytes.find('\n', pos);
    if (nl == std::string::npos || nl - pos > 4096) throw StateFileError(K::kCorrupt, "state: truncated header");
    l = bytes.substr(pos, nl - pos);
    pos = nl + 1;
  }
  if (lines[0].rfind(std::string(kMagic) + ' ', 0) != 0) throw StateFileError(K::kCorrupt, "state: not an ndsid state file (bad magic)");
  const std::string version = lines[0].substr(kMagic.size() + 1);
  if (version != std::to_string(kStateFormatVersion) && version != "1") {
    throw StateFileError(K::kIncompatible, "state: format version " + version + ", this ndsidd reads versions 1 to " +
                                               std::to_string(kStateFormatVersion));
  }
  if (lines[1].rfind("vehicle ", 0) != 0) throw StateFileError(K::kCorrupt, "state: missing vehicle line");
  const std::string file_vehicle = lines[1].substr(8);
  if (file_vehicle != OneLine(vehicle)) {
    throw StateFileError(K::kForeign, "state: belongs to vehicle '" + file_vehicle + "', configured vehicle is '" + vehicle + "'");
  }
  unsigned long long n = 0, checksum = 0;
  if (std::sscanf(lines[2].c_str(), "payload_bytes %llu", &n) != 1 ||
      std::sscanf(lines[3].c_str(), "payload_fnv1a64 %16llx", &checksum) != 1 || !lines[4].empty()) {
    throw StateFileError(K::kCorrupt, "state: malformed header");
  }
  if (bytes.size() - pos != n) {
    throw StateFileError(K::kCorrupt, "state: payload is " + std::to_string(bytes.size() - pos) + " bytes, header says " +
                                          std::to_string(n) + " (truncated?)");
  }
  const std::string_view payload(bytes.data() + pos, n);
  if (Fnv1a64(payload) != checksum) throw StateFileError(K::kCorrupt, "state: checksum mismatch (payload damaged)");
  try {
    const nlohmann::json doc = version == "1" ? MigrateStateV1(payload) : ParseCbor(payload, "state payload");
    return FromDocument(doc, file_vehicle);
  } catch (const StateFileError&) {
    throw;
  } catch (const Error& e) {
    throw StateFileError(K::kCorrupt, e.what());
  }
}

// ---- StateStore --------------------------------------------------------------------------

StateStore::StateStore(std::string state_dir, std::string vehicle)
    : dir_(std::move(state_dir)), vehicle_(std::move(vehicle)),
      path_((std::filesystem::path(dir_) / StateFileName(vehicle_)).string()) {}

StateStore::LoadResult StateStore::Load() {
  LoadResult r;
  std::error_code ec;
  if (!std::filesystem::exists(path_, ec)) {
    r.message = "no learned state at " + path_ + ": starting fresh";
    return r;
  }
  std::string bytes;
  try {
    bytes = ReadWholeFile(path_);
  } catch (const Error& e) {
    r.unreadable = true;
    r.message = "learned state " + path_ + " exists but cannot be read (" + e.what() +
                "): stopping rather than overwriting it; fix its permissions (the service's user must read it) or move it away (or set state_unreadable: run_without_persisting to estimate without saving)";
    return r;
  }
  try {
    r.state = DecodeState(bytes, vehicle_);
    r.message = "learned state loaded from " + path_;
  } catch (const StateFileError& e) {
    const std::string tag = e.kind() == StateFileError::Kind::kForeign ? "foreign" : "corrupt";
    const std::string moved = Quarantine(tag);
    r.message = std::string(e.what()) + ": moved aside to " + (moved.empty() ? "(move failed)" : moved) + ", starting fresh";
  }
  return r;
}

int StateStore::RemoveTemporaries() const {
  const std::string prefix = "." + std::filesystem::path(path_).filename().string() + ".tmp";
  std::error_code ec;
  int removed = 0;
  for (std::filesystem::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    std::error_code rm;
    if (std::filesystem::remove(it->path(), rm)) ++removed;
  }
  return removed;
}

void StateStore::Save(const LearnedState& state) const {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec) throw Error("state_dir " + dir_ + ": cannot create: " + ec.message());
  WriteFileAtomically(path_, EncodeState(state));
}

std::string StateStore::Quarantine(const std::string& tag) const {
  std::string target = path_ + "." + tag + "-" + UtcStamp();
  std::error_code ec;
  for (int i = 1; std::filesystem::exists(target, ec) && i < 100; ++i) {
    target = path_ + "." + tag + "-" + UtcStamp() + "-" + std::to_string(i);
  }
  std::filesystem::rename(path_, target, ec);
  if (ec) {
    spdlog::error("state: cannot move {} aside to {}: {}", path_, target, ec.message());
    return "";
  }
  return target;
}

// ---- Pipeline <-> LearnedState -----------------------------------------------------------

LearnedState CaptureState(const pipeline::Pipeline& pipeline, const config::Config& config, int32_t identifications) {
  LearnedState st;
  st.vehicle = config.vehicle.name;
  st.data_time_ns = pipeline.data_time_ns();
  st.saved_unix_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  st.identifications = identifications;
  st.last_fit_gated_hours = pipeline.last_fit_gated_hours();
  st.accumulator = pipeline.accumulator().ToJson();
  st.adequacy = pipeline.adequacy().ToJson();
  st.last_estimate = pipeline.last_estimate();
  st.stops.assign(pipeline.stops().begin(), pipeline.stops().end());  // at most kMaxPersistedStops
  st.linearized = pipeline.linearized();  // immutable: shared with the persist thread
  return st;
}

std::string CheckEstimate(const pipeline::Estimate& e, const config::Config& config) {
  const identify::IdentificationResult& f = e.fit;
  if (!f.valid) return "";  // an invalid estimate carries its reason and is never used as a value
  for (double v : {f.eg_rad_per_mps2, f.eg_se_rad_per_mps2, f.eg_deg_per_g, e.gated_hours}) {
    if (!std::isfinite(v)) return "non-finite EG";
  }
  for (int i = 0; i < model::kNumParams; ++i) {
    const double v = f.params[i].value;
    const config::ParameterSpec& box = config.identification.params[i];
    const double slack = kBoxSlack * std::max(std::abs(box.lower), std::abs(box.upper));
    if (!std::isfinite(v) || !std::isfinite(f.params[i].se)) return std::string("non-finite ") + model::kParamNames[i];
    if (v < box.lower - slack || v > box.upper + slack) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "%s = %g outside the configured box [%g, %g]", model::kParamNames[i], v, box.lower,
                    box.upper);
      return buf;
    }
  }
  for (const identify::ParameterEstimate& p : f.effect_params) {
    if (!std::isfinite(p.value) || !std::isfinite(p.se)) return "non-finite effect parameter " + p.name;
  }
  // Base model only: effects may change how EG follows from the parameters.
  const double eg = model::SelfSteerGradient(f.AsParams(), config.vehicle.wheelbase_m);
  if (f.effect_params.empty() && std::abs(eg - f.eg_rad_per_mps2) > 1e-6 * std::max(1e-3, std::abs(eg))) {
    return "EG does not follow from the parameters (state inconsistent)";
  }
  return "";
}

void RestoreState(pipeline::Pipeline& pipeline, const config::Config& config, const LearnedState& st, std::string& dropped) {
  using K = StateFileError::Kind;
  dropped.clear();
  if (st.vehicle != config.vehicle.name) throw StateFileError(K::kForeign, "state of vehicle '" + st.vehicle + "'");
  // Check everything on scratch objects first, so a bad state leaves the pipeline untouched.
  stats::Accumulator acc(config, config.sync.rate_hz);
  adequacy::Tracker tracker(config.adequacy);
  try {
    acc.FromJson(JsonIn(st.accumulator, "state.accumulator"));
    tracker.FromJson(JsonIn(st.adequacy, "state.adequacy"));
  } catch (const StateFileError&) {
    throw;
  } catch (const Error& e) {
    throw StateFileError(K::kCorrupt, e.what());
  }
  if (!std::isfinite(st.last_fit_gated_hours)) throw StateFileError(K::kCorrupt, "non-finite last_fit_gated_hours");
  std::optional<pipeline::Estimate> last = st.last_estimate;
  if (last) {
    dropped = CheckEstimate(*last, config);
    if (!dropped.empty()) last.reset();
  }
  pipeline.mutable_accumulator().FromJson(JsonIn(st.accumulator, "state.accumulator"));
  pipeline.mutable_adequacy().FromJson(JsonIn(st.adequacy, "state.adequacy"));
  pipeline.RestoreLastEstimate(std::move(last), std::min(st.last_fit_gated_hours, pipeline.accumulator().gated_hours()));
  pipeline.RestoreStops(st.stops);
  pipeline.RestoreLinearized(st.linearized);
}

}  // namespace ndsid::service
