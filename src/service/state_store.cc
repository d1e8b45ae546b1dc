#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>

#include "ndsid/common/atomic_file.h"
#include "state_store.h"

namespace ndsid::service {

namespace {

constexpr std::string_view kMagic = "NDSID-STATE";
constexpr double kBoxSlack = 1e-9;  // relative: a value on the box edge is inside

// ---- Estimate as "key value" lines --------------------------------------------------------

std::string OneLine(std::string s) {
  for (char& c : s) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return s;
}

class KeyWriter {
 public:
  KeyWriter() { os_.precision(17); }
  template <typename T>
  void Put(const std::string& key, const T& v) {
    os_ << key << ' ' << v << '\n';
  }
  void PutString(const std::string& key, const std::string& v) { os_ << key << ' ' << OneLine(v) << '\n'; }
  std::string str() const { return os_.str(); }

 private:
  std::ostringstream os_;
};

class KeyReader {
 public:
  explicit KeyReader(const std::string& text) {
    std::istringstream is(text);
    std::string line;
    while (std::getline(is, line)) {
      const auto sp = line.find(' ');
      if (sp == std::string::npos) {
        values_[line] = "";
      } else {
        values_[line.substr(0, sp)] = line.substr(sp + 1);
      }
    }
  }
  const std::string& String(const std::string& key) const {
    const auto it = values_.find(key);
    if (it == values_.end()) throw StateFileError(StateFileError::Kind::kCorrupt, "state: missing key '" + key + "'");
    return it->second;
  }
  double Number(const std::string& key) const {
    const std::string& s = String(key);
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || errno == ERANGE) {
      throw StateFileError(StateFileError::Kind::kCorrupt, "state: key '" + key + "' is not a number: '" + s + "'");
    }
    return v;  // may be nan/inf: the sanity checks decide
  }
  int64_t Integer(const std::string& key) const { return static_cast<int64_t>(std::llround(Number(key))); }
  int64_t Int64(const std::string& key) const {
    const std::string& s = String(key);
    try {
      return std::stoll(s);
    } catch (const std::exception&) {
      throw StateFileError(StateFileError::Kind::kCorrupt, "state: key '" + key + "' is not an integer: '" + s + "'");
    }
  }
  bool Flag(const std::string& key) const { return Number(key) != 0; }

 private:
  std::map<std::string, std::string> values_;
};

std::string EncodeEstimate(const pipeline::Estimate& e) {
  KeyWriter w;
  w.Put("data_time_ns", e.data_time_ns);
  w.Put("gated_hours", e.gated_hours);
  w.Put("window_hours", e.window_hours);
  w.Put("training_segments", e.training_segments);
  w.Put("validation_segments", e.validation_segments);
  const identify::IdentificationResult& f = e.fit;
  w.Put("fit.valid", int{f.valid});
  w.PutString("fit.reason", f.reason);
  for (int i = 0; i < model::kNumParams; ++i) {
    const std::string k = std::string("fit.param.") + model::kParamNames[i];
    w.Put(k + ".value", f.params[i].value);
    w.Put(k + ".se", f.params[i].se);
    w.Put(k + ".fixed", int{f.params[i].fixed});
    w.Put(k + ".at_bound", int{f.params[i].at_bound});
  }
  w.Put("fit.eg", f.eg_rad_per_mps2);
  w.Put("fit.eg_se", f.eg_se_rad_per_mps2);
  w.Put("fit.eg_deg_per_g", f.eg_deg_per_g);
  w.Put("fit.eg_se_deg_per_g", f.eg_se_deg_per_g);
  w.PutString("fit.model", f.model);
  w.Put("fit.effect_count", f.effect_params.size());
  for (size_t i = 0; i < f.effect_params.size(); ++i) {
    const identify::ParameterEstimate& p = f.effect_params[i];
    const std::string k = "fit.effect." + std::to_string(i);
    w.PutString(k + ".name", p.name);
    w.PutString(k + ".unit", p.unit);
    w.Put(k + ".value", p.value);
    w.Put(k + ".se", p.se);
    w.Put(k + ".fixed", int{p.fixed});
    w.Put(k + ".at_bound", int{p.at_bound});
  }
  std::ostringstream corr;
  corr.precision(17);
  corr << f.correlation.size();
  for (double c : f.correlation) corr << ' ' << c;
  w.PutString("fit.correlation", corr.str());
  w.Put("fit.rmse_train", f.rmse_train_mps2);
  w.Put("fit.rmse_validation", f.rmse_validation_mps2);
  w.Put("fit.residuals_train", f.residuals_train);
  w.Put("fit.residuals_validation", f.residuals_validation);
  w.Put("fit.chunks", f.chunks);
  w.Put("fit.train_hours", f.train_hours);
  w.Put("fit.iterations", f.iterations);
  w.Put("fit.solve_seconds", f.solve_seconds);
  w.PutString("fit.termination", f.termination);
  w.PutString("fit.se_method", f.se_method);
  const stats::SteadyStateEstimate& s = e.steady_state;
  w.Put("steady.valid", int{s.valid});
  w.PutString("steady.reason", s.reason);
  w.Put("steady.steer_ratio", s.steer_ratio);
  w.Put("steady.eg", s.eg_rad_per_mps2);
  w.Put("steady.eg_se", s.eg_se);
  w.Put("steady.steer_offset_rad", s.steer_offset_rad);
  w.Put("steady.n", s.n);
  const adequacy::Report& a = e.adequacy;
  w.Put("adequacy.state", static_cast<int>(a.state));
  w.Put("adequacy.gated_hours", a.gated_hours);
  w.Put("adequacy.rel_change", a.rel_change);
  w.Put("adequacy.rel_se", a.rel_se);
  w.Put("adequacy.kl_growth", a.kl_growth);
  w.Put("adequacy.hours_under_tolerance", a.hours_under_tolerance);
  w.PutString("adequacy.explanation", a.explanation);
  return w.str();
}

pipeline::Estimate DecodeEstimate(const std::string& text) {
  const KeyReader r(text);
  pipeline::Estimate e;
  e.data_time_ns = r.Int64("data_time_ns");
  e.gated_hours = r.Number("gated_hours");
  e.window_hours = r.Number("window_hours");
  e.training_segments = static_cast<size_t>(std::max<int64_t>(0, r.Integer("training_segments")));
  e.validation_segments = static_cast<size_t>(std::max<int64_t>(0, r.Integer("validation_segments")));
  identify::IdentificationResult& f = e.fit;
  f.valid = r.Flag("fit.valid");
  f.reason = r.String("fit.reason");
  for (int i = 0; i < model::kNumParams; ++i) {
    const std::string k = std::string("fit.param.") + model::kParamNames[i];
    f.params[i].name = model::kParamNames[i];
    f.params[i].unit = model::kParamUnits[i];
    f.params[i].value = r.Number(k + ".value");
    f.params[i].se = r.Number(k + ".se");
    f.params[i].fixed = r.Flag(k + ".fixed");
    f.params[i].at_bound = r.Flag(k + ".at_bound");
  }
  f.eg_rad_per_mps2 = r.Number("fit.eg");
  f.eg_se_rad_per_mps2 = r.Number("fit.eg_se");
  f.eg_deg_per_g = r.Number("fit.eg_deg_per_g");
  f.eg_se_deg_per_g = r.Number("fit.eg_se_deg_per_g");
  f.model = r.String("fit.model");
  const int64_t effects = r.Integer("fit.effect_count");
  if (effects < 0 || effects > 64) throw StateFileError(StateFileError::Kind::kCorrupt, "state: implausible effect count");
  for (int64_t i = 0; i < effects; ++i) {
    const std::string k = "fit.effect." + std::to_string(i);
    identify::ParameterEstimate p;
    p.name = r.String(k + ".name");
    p.unit = r.String(k + ".unit");
    p.value = r.Number(k + ".value");
    p.se = r.Number(k + ".se");
    p.fixed = r.Flag(k + ".fixed");
    p.at_bound = r.Flag(k + ".at_bound");
    f.effect_params.push_back(std::move(p));
  }
  std::istringstream corr(r.String("fit.correlation"));
  size_t n_corr = 0;
  corr >> n_corr;
  if (corr.fail() || n_corr > 64 * 64) throw StateFileError(StateFileError::Kind::kCorrupt, "state: bad correlation matrix");
  f.correlation.resize(n_corr);
  for (double& c : f.correlation) corr >> c;
  f.rmse_train_mps2 = r.Number("fit.rmse_train");
  f.rmse_validation_mps2 = r.Number("fit.rmse_validation");
  f.residuals_train = static_cast<size_t>(std::max<int64_t>(0, r.Integer("fit.residuals_train")));
  f.residuals_validation = static_cast<size_t>(std::max<int64_t>(0, r.Integer("fit.residuals_validation")));
  f.chunks = static_cast<size_t>(std::max<int64_t>(0, r.Integer("fit.chunks")));
  f.train_hours = r.Number("fit.train_hours");
  f.iterations = static_cast<int>(r.Integer("fit.iterations"));
  f.solve_seconds = r.Number("fit.solve_seconds");
  f.termination = r.String("fit.termination");
  f.se_method = r.String("fit.se_method");
  stats::SteadyStateEstimate& s = e.steady_state;
  s.valid = r.Flag("steady.valid");
  s.reason = r.String("steady.reason");
  s.steer_ratio = r.Number("steady.steer_ratio");
  s.eg_rad_per_mps2 = r.Number("steady.eg");
  s.eg_se = r.Number("steady.eg_se");
  s.steer_offset_rad = r.Number("steady.steer_offset_rad");
  s.n = r.Number("steady.n");
  adequacy::Report& a = e.adequacy;
  a.state = static_cast<adequacy::State>(std::clamp<int64_t>(r.Integer("adequacy.state"), 0, 2));
  a.gated_hours = r.Number("adequacy.gated_hours");
  a.rel_change = r.Number("adequacy.rel_change");
  a.rel_se = r.Number("adequacy.rel_se");
  a.kl_growth = r.Number("adequacy.kl_growth");
  a.hours_under_tolerance = r.Number("adequacy.hours_under_tolerance");
  a.explanation = r.String("adequacy.explanation");
  return e;
}

// ---- Standstill stops as JSON -------------------------------------------------------------
// [{"drive":n,"t_start_ns":n,"seconds":x,"samples":n,"mean_lat_accel_mps2":x,
//   "mean_yaw_rate_radps":x|null}, ...]  (null: the bus had no yaw rate)

std::string EncodeStops(const std::vector<gate::StandstillStop>& stops) {
  nlohmann::json a = nlohmann::json::array();
  for (const gate::StandstillStop& s : stops) {
    nlohmann::json j{{"drive", s.drive_id}, {"t_start_ns", s.t_start_ns}, {"seconds", s.seconds}, {"samples", s.samples},
                     {"mean_lat_accel_mps2", s.mean_lat_accel_mps2}};
    j["mean_yaw_rate_radps"] = std::isfinite(s.mean_yaw_rate_radps) ? nlohmann::json(s.mean_yaw_rate_radps) : nlohmann::json();
    a.push_back(std::move(j));
  }
  return a.dump();
}

std::vector<gate::StandstillStop> DecodeStops(const std::string& text) {
  using K = StateFileError::Kind;
  nlohmann::json a;
  try {
    a = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw StateFileError(K::kCorrupt, std::string("state: standstill section: ") + e.what());
  }
  if (!a.is_array()) throw StateFileError(K::kCorrupt, "state: standstill section is not an array");
  if (a.size() > kMaxPersistedStops) {
    throw StateFileError(K::kCorrupt, "state: standstill section holds " + std::to_string(a.size()) + " stops (at most " +
                                          std::to_string(kMaxPersistedStops) + ")");
  }
  std::vector<gate::StandstillStop> out;
  out.reserve(a.size());
  for (size_t i = 0; i < a.size(); ++i) {
    const nlohmann::json& j = a[i];
    const std::string where = "state: standstill stop " + std::to_string(i) + ": ";
    auto number = [&](const char* key) -> const nlohmann::json& {
      if (!j.is_object() || !j.contains(key) || !j[key].is_number())
        throw StateFileError(K::kCorrupt, where + "'" + key + "' missing or not a number");
      return j[key];
    };
    auto integer = [&](const char* key) -> const nlohmann::json& {
      const nlohmann::json& v = number(key);
      if (!v.is_number_integer()) throw StateFileError(K::kCorrupt, where + "'" + key + "' is not an integer");
      return v;
    };
    gate::StandstillStop s;
    s.drive_id = integer("drive").get<int64_t>();
    s.t_start_ns = integer("t_start_ns").get<int64_t>();
    if (!integer("samples").is_number_unsigned()) throw StateFileError(K::kCorrupt, where + "'samples' is negative");
    s.samples = j["samples"].get<uint64_t>();
    s.seconds = number("seconds").get<double>();
    s.mean_lat_accel_mps2 = number("mean_lat_accel_mps2").get<double>();
    if (!j.contains("mean_yaw_rate_radps")) throw StateFileError(K::kCorrupt, where + "'mean_yaw_rate_radps' missing");
    const nlohmann::json& r = j["mean_yaw_rate_radps"];
    if (!r.is_null() && !r.is_number()) throw StateFileError(K::kCorrupt, where + "'mean_yaw_rate_radps' not a number");
    s.mean_yaw_rate_radps = r.is_null() ? std::numeric_limits<double>::quiet_NaN() : r.get<double>();
    // A stop is at most a (very long) parking of 10^7 s; the mean a_y a few g at the most.
    if (s.drive_id < 0 || s.samples == 0 || !(s.seconds > 0 && s.seconds <= 1e7) || !(std::abs(s.mean_lat_accel_mps2) <= 1e3) ||
        !(std::isnan(s.mean_yaw_rate_radps) || std::abs(s.mean_yaw_rate_radps) <= 1e3))
      throw StateFileError(K::kCorrupt, where + "out of range (drive, samples, seconds, mean a_y or mean yaw rate)");
    out.push_back(s);
  }
  return out;
}

// ---- Sections ----------------------------------------------------------------------------

void PutSection(std::string& out, const std::string& name, const std::string& bytes) {
  out += name + ' ' + std::to_string(bytes.size()) + '\n';
  out += bytes;
  out += '\n';
}

std::map<std::string, std::string> SplitSections(const std::string& payload) {
  std::map<std::string, std::string> sections;
  size_t pos = 0;
  while (pos < payload.size()) {
    const size_t nl = payload.find('\n', pos);
    if (nl == std::string::npos) throw StateFileError(StateFileError::Kind::kCorrupt, "state: truncated section header");
    std::istringstream hs(payload.substr(pos, nl - pos));
    std::string name;
    uint64_t n = 0;
    hs >> name >> n;
    if (hs.fail() || n > payload.size() - (nl + 1) || payload.size() - (nl + 1) - n < 1 || payload[nl + 1 + n] != '\n') {
      throw StateFileError(StateFileError::Kind::kCorrupt, "state: malformed section '" + name + "'");
    }
    sections[name] = payload.substr(nl + 1, n);
    pos = nl + 1 + n + 1;
  }
  return sections;
}

std::string UtcStamp() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%dT%H%M%SZ", &tm);
  return buf;
}

bool Finite(std::initializer_list<double> values) {
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
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
  std::string payload;
  {
    KeyWriter meta;
    meta.Put("data_time_ns", st.data_time_ns);
    meta.Put("saved_unix_ns", st.saved_unix_ns);
    meta.Put("identifications", st.identifications);
    meta.Put("last_fit_gated_hours", st.last_fit_gated_hours);
    PutSection(payload, "meta", meta.str());
  }
  PutSection(payload, "accumulator", st.accumulator);
  PutSection(payload, "adequacy", st.adequacy);
  if (st.last_estimate) PutSection(payload, "estimate", EncodeEstimate(*st.last_estimate));
  if (!st.stops.empty()) PutSection(payload, "standstill", EncodeStops(st.stops));
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
  if (version != std::to_string(kStateFormatVersion)) {
    throw StateFileError(K::kIncompatible, "state: format version " + version + ", this ndsidd reads version " +
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

  const auto sections = SplitSections(std::string(payload));
  auto section = [&](const std::string& name) -> const std::string& {
    const auto it = sections.find(name);
    if (it == sections.end()) throw StateFileError(K::kCorrupt, "state: missing section '" + name + "'");
    return it->second;
  };
  LearnedState st;
  st.vehicle = file_vehicle;
  const KeyReader meta(section("meta"));
  st.data_time_ns = meta.Int64("data_time_ns");
  st.saved_unix_ns = meta.Int64("saved_unix_ns");
  st.identifications = static_cast<int32_t>(meta.Integer("identifications"));
  st.last_fit_gated_hours = meta.Number("last_fit_gated_hours");
  st.accumulator = section("accumulator");
  st.adequacy = section("adequacy");
  if (sections.count("estimate")) st.last_estimate = DecodeEstimate(sections.at("estimate"));
  if (sections.count("standstill")) st.stops = DecodeStops(sections.at("standstill"));
  return st;
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
  st.accumulator = pipeline.accumulator().Serialize();
  st.adequacy = pipeline.adequacy().Serialize();
  st.last_estimate = pipeline.last_estimate();
  st.stops.assign(pipeline.stops().begin(), pipeline.stops().end());  // at most kMaxPersistedStops
  return st;
}

std::string CheckEstimate(const pipeline::Estimate& e, const config::Config& config) {
  const identify::IdentificationResult& f = e.fit;
  if (!f.valid) return "";  // an invalid estimate carries its reason and is never used as a value
  if (!Finite({f.eg_rad_per_mps2, f.eg_se_rad_per_mps2, f.eg_deg_per_g, e.gated_hours})) return "non-finite EG";
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
    acc.Restore(st.accumulator);
    tracker.Deserialize(st.adequacy);
  } catch (const StateFileError&) {
    throw;
  } catch (const Error& e) {
    throw StateFileError(K::kCorrupt, e.what());
  }
  for (const adequacy::EgPoint& p : tracker.history()) {
    if (!Finite({p.gated_hours, p.eg, p.eg_se, p.kl})) throw StateFileError(K::kCorrupt, "adequacy history: non-finite value");
  }
  if (!std::isfinite(st.last_fit_gated_hours)) throw StateFileError(K::kCorrupt, "non-finite last_fit_gated_hours");
  std::optional<pipeline::Estimate> last = st.last_estimate;
  if (last) {
    dropped = CheckEstimate(*last, config);
    if (!dropped.empty()) last.reset();
  }
  pipeline.mutable_accumulator().Restore(st.accumulator);
  pipeline.mutable_adequacy().Deserialize(st.adequacy);
  pipeline.RestoreLastEstimate(std::move(last), std::min(st.last_fit_gated_hours, pipeline.accumulator().gated_hours()));
  pipeline.RestoreStops(st.stops);
}

}  // namespace ndsid::service
