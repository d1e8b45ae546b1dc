#include "state_migration.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>
#include <type_traits>

#include "ndsid/common/json_codec.h"
#include "ndsid/pipeline/estimate_codec.h"
#include "state_store.h"

namespace ndsid::service {

namespace {

// ---- The estimate as "key value" lines -----------------------------------------------------

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

// ---- Sections -------------------------------------------------------------------------------

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

// ---- Statistics as text lines ----------------------------------------------------------------

std::vector<double> TextNumbers(const std::string& text, const char* what) {
  std::istringstream is(text);
  std::vector<double> v;
  std::string token;
  while (is >> token) {
    char* end = nullptr;
    const double x = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') throw Error(std::string(what) + ": '" + token + "' is not a number");
    v.push_back(x);
    if (v.size() > (size_t{1} << 20)) throw Error(std::string(what) + ": too many numbers");
  }
  return v;
}

nlohmann::json RegressionText(const std::string& text) {
  const std::vector<double> v = TextNumbers(text, "regression statistics");
  if (v.size() != 14) throw Error("regression statistics: " + std::to_string(v.size()) + " numbers, expected 14");
  return {{"xtx", std::vector<double>(v.begin(), v.begin() + 9)}, {"xty", std::vector<double>(v.begin() + 9, v.begin() + 12)},
          {"yty", v[12]}, {"n", v[13]}};
}

nlohmann::json SteadyText(const std::string& text) {
  const auto bar = text.find('|');
  if (bar == std::string::npos) throw Error("steady-state statistics: missing '|' separator");
  return {{"without_yaw", RegressionText(text.substr(0, bar))}, {"with_yaw", RegressionText(text.substr(bar + 1))}};
}

// "<n> c1 .. cn <m> c1 .. cm"
nlohmann::json CoverageText(const std::string& text) {
  const std::vector<double> v = TextNumbers(text, "coverage");
  nlohmann::json j;
  size_t pos = 0;
  for (const char* key : {"gg", "v_ay"}) {
    if (pos >= v.size() || !(v[pos] >= 0) || v[pos] > static_cast<double>(v.size() - pos - 1))
      throw Error("coverage: histogram size mismatch");
    const size_t n = static_cast<size_t>(v[pos]);
    j[key] = std::vector<double>(v.begin() + static_cast<long>(pos + 1), v.begin() + static_cast<long>(pos + 1 + n));
    pos += 1 + n;
  }
  if (pos != v.size()) throw Error("coverage: trailing data after the histograms");
  return j;
}

nlohmann::json AdequacyText(const std::string& text) {
  std::istringstream is(text);
  size_t n = 0;
  is >> n;
  if (is.fail() || n > adequacy::Tracker::kMaxHistoryPoints) throw Error("adequacy state: bad history length");
  nlohmann::json j;
  j["history"] = nlohmann::json::array();
  for (size_t i = 0; i < n; ++i) {
    double h = 0, eg = 0, se = 0, kl = 0;
    is >> h >> eg >> se >> kl;
    if (is.fail()) throw Error("adequacy state: history truncated at point " + std::to_string(i) + " of " + std::to_string(n));
    j["history"].push_back({{"gated_hours", h}, {"eg", eg}, {"eg_se", se}, {"kl", kl}});
  }
  size_t ns = 0;
  is >> ns;
  if (is.fail() || ns > adequacy::Tracker::kMaxSnapshots) throw Error("adequacy state: bad snapshot count");
  j["snapshots"] = nlohmann::json::array();
  std::string line;
  std::getline(is, line);
  for (size_t i = 0; i < ns; ++i) {
    if (!std::getline(is, line)) throw Error("adequacy state: truncated snapshots");
    std::istringstream ls(line);
    double hours = 0;
    ls >> hours;
    std::string rest;
    std::getline(ls, rest);
    j["snapshots"].push_back({{"hours", hours}, {"coverage", CoverageText(rest)}});
  }
  int state = 0;
  double under = -1;
  is >> under >> state;
  if (is.fail()) throw Error("adequacy state: truncated");
  j["under_since_hours"] = under;
  j["state"] = adequacy::StateName(static_cast<adequacy::State>(std::clamp(state, 0, 2)));
  return j;
}

// ---- The accumulator's binary layout (host byte order), tags ACC1 and ACC2 ---------------------

constexpr char kAccumulatorTagV1[4] = {'A', 'C', 'C', '1'};  // without the open drive
constexpr char kAccumulatorTagV2[4] = {'A', 'C', 'C', '2'};  // + the open drive
constexpr uint64_t kMaxCount = uint64_t{1} << 32;

class ByteReader {
 public:
  explicit ByteReader(std::string_view in) : in_(in) {}
  template <typename T>
  T Get() {
    static_assert(std::is_trivially_copyable_v<T>);
    if (in_.size() - pos_ < sizeof(T)) throw Error("accumulator state: truncated");
    T v;
    std::memcpy(&v, in_.data() + pos_, sizeof v);
    pos_ += sizeof v;
    return v;
  }
  uint64_t Count() {
    const uint64_t n = Get<uint64_t>();
    if (n > kMaxCount || n > in_.size() - pos_ + 1) throw Error("accumulator state: implausible count");
    return n;
  }
  std::string Blob() {
    const uint64_t n = Count();
    if (in_.size() - pos_ < n) throw Error("accumulator state: truncated");
    std::string s(in_.substr(pos_, n));
    pos_ += n;
    return s;
  }
  std::vector<float> Floats(size_t count) {
    if ((in_.size() - pos_) / sizeof(float) < count) throw Error("accumulator state: truncated");
    std::vector<float> v(count);
    std::memcpy(v.data(), in_.data() + pos_, count * sizeof(float));
    pos_ += count * sizeof(float);
    return v;
  }
  int Version() {
    char t[4];
    for (char& c : t) c = Get<char>();
    if (std::memcmp(t, kAccumulatorTagV2, 4) == 0) return 2;
    if (std::memcmp(t, kAccumulatorTagV1, 4) == 0) return 1;
    throw Error("accumulator state: wrong tag (not an accumulator state, or another version)");
  }
  bool done() const { return pos_ == in_.size(); }

 private:
  std::string_view in_;
  size_t pos_ = 0;
};

static_assert(sizeof(float) == 4 && std::is_trivially_copyable_v<float>);
constexpr size_t kSampleFloats = 5;  // the layout of stats::SegmentSample

nlohmann::json LegacySegment(ByteReader& r) {
  nlohmann::json j;
  j["t0_ns"] = r.Get<int64_t>();
  j["drive"] = r.Get<int64_t>();
  j["dt_s"] = r.Get<double>();
  j["has_yaw_rate"] = r.Get<uint8_t>() != 0;
  j["has_long_accel"] = r.Get<uint8_t>() != 0;
  const uint64_t n = r.Count();
  const std::vector<float> f = r.Floats(n * kSampleFloats);
  j["samples"] = FloatsToBinary(f.data(), f.size());
  return j;
}

nlohmann::json LegacyAccumulator(std::string_view bytes) {
  ByteReader r(bytes);
  const int version = r.Version();
  nlohmann::json j;
  j["gated_s"] = r.Get<double>();
  const uint64_t c0 = r.Get<uint64_t>(), c1 = r.Get<uint64_t>(), c2 = r.Get<uint64_t>();
  j["counters"] = {{"short_drive_samples", c0}, {"short_segment_samples", c1}, {"evicted_segments", c2}};
  j["steady_state"] = SteadyText(r.Blob());
  j["coverage"] = CoverageText(r.Blob());
  j["drives"] = nlohmann::json::array();
  for (uint64_t i = 0, n = r.Count(); i < n; ++i) {
    nlohmann::json d;
    d["drive"] = r.Get<int64_t>();
    d["start_ns"] = r.Get<int64_t>();
    d["end_ns"] = r.Get<int64_t>();
    d["distance_km"] = r.Get<double>();
    d["gated_s"] = r.Get<double>();
    d["used"] = r.Get<uint8_t>() != 0;
    j["drives"].push_back(std::move(d));
  }
  j["window"] = nlohmann::json::array();
  for (uint64_t i = 0, n = r.Count(); i < n; ++i) j["window"].push_back(LegacySegment(r));
  j["open_drive"] = nullptr;
  if (version >= 2 && r.Get<uint8_t>() != 0) {
    nlohmann::json o;
    o["used"] = r.Get<uint8_t>() != 0;
    o["pending_gated_s"] = r.Get<double>();
    o["pending_samples"] = r.Get<uint64_t>();
    o["pending_steady_state"] = SteadyText(r.Blob());
    o["pending_coverage"] = CoverageText(r.Blob());
    o["pending_segments"] = nlohmann::json::array();
    for (uint64_t i = 0, n = r.Count(); i < n; ++i) o["pending_segments"].push_back(LegacySegment(r));
    o["open_segment"] = nullptr;
    if (r.Get<uint8_t>() != 0) {
      nlohmann::json s;
      s["segment"] = LegacySegment(r);
      s["summed"] = r.Get<int32_t>();
      const std::vector<float> sum = r.Floats(kSampleFloats);
      s["sum"] = FloatsToBinary(sum.data(), sum.size());
      s["sum_t0_ns"] = r.Get<int64_t>();
      o["open_segment"] = std::move(s);
    }
    j["open_drive"] = std::move(o);
  }
  if (!r.done()) throw Error("accumulator state: trailing bytes");
  return j;
}

}  // namespace

nlohmann::json MigrateStateV1(std::string_view payload) {
  const auto sections = SplitSections(std::string(payload));
  auto section = [&](const std::string& name) -> const std::string& {
    const auto it = sections.find(name);
    if (it == sections.end()) throw Error("state: missing section '" + name + "'");
    return it->second;
  };
  const KeyReader meta(section("meta"));
  nlohmann::json doc;
  doc["data_time_ns"] = meta.Int64("data_time_ns");
  doc["saved_unix_ns"] = meta.Int64("saved_unix_ns");
  doc["identifications"] = meta.Integer("identifications");
  doc["last_fit_gated_hours"] = meta.Number("last_fit_gated_hours");
  doc["accumulator"] = LegacyAccumulator(section("accumulator"));
  doc["adequacy"] = AdequacyText(section("adequacy"));
  doc["estimate"] = sections.count("estimate") ? pipeline::EstimateToJson(DecodeEstimate(sections.at("estimate"))) : nlohmann::json();
  doc["standstill"] = nlohmann::json::array();
  if (sections.count("standstill")) {
    try {
      doc["standstill"] = nlohmann::json::parse(sections.at("standstill"));
    } catch (const nlohmann::json::exception& e) {
      throw Error(std::string("state: standstill section: ") + e.what());
    }
  }
  return doc;
}

}  // namespace ndsid::service
